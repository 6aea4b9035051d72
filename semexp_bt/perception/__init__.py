"""Perception: the perception-source interface the executive calls, the embedding and LLM relevance
scorers, and the home of model adapters.

May import: ``semexp_bt.nav`` and ``semexp_bt.core``; a model's own library (torch,
sentence-transformers, an HTTP client) only lazily, inside the adapter that needs it.
"""
