"""Reading the files a user hands the product: one safe YAML reader (``yaml_source``) for mission trees,
config files, robot profiles and model profiles, so every such file is refused the same way (not a
regular file, too big, not UTF-8, tabs, deep nesting, alias bombs, duplicate keys, non-plain tags) with
one line naming the file, the line and the column.

May import: ``semexp_bt.core``, PyYAML and the standard library. It sits just above the core so that
every layer that reads a user's file (robots, trees, the application) may use it, while the core itself
stays free of file formats.
"""
