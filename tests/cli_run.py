"""Run a command line's ``main`` in-process, as its tests do."""

from collections.abc import Callable


def run_main(main: Callable[[list[str]], int], capsys, *argv) -> tuple[int, str, str]:
    """``main(ARGV)``: (exit status, stdout, stderr), after checking that an error is exactly
    one line ``error: ...`` and that no traceback is shown."""
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    if code != 0:
        lines = [line for line in err.splitlines() if line.strip()]
        assert len(lines) == 1 and lines[0].startswith("error: "), err
        assert "Traceback" not in err
    return code, out, err
