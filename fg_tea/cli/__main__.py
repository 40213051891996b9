"""``python -m fg_tea.cli``: the same as the ``fg-tea`` command."""

from fg_tea.cli.main import main

raise SystemExit(main())
