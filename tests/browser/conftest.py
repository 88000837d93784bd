"""tests/browser holds the JupyterLab + Chromium run of `make browser`, not pytest tests:
`make test` (pytest --doctest-modules tests) must not import it (Playwright may be missing)."""

collect_ignore_glob = ["*.py"]
