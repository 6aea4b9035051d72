from semexp_bt.cli import main

raise SystemExit(main())
