"""``python -m wbc`` = the ``wbc`` console script."""

import sys

try:
    from wbc.cli import main
except KeyboardInterrupt:  # Ctrl-C before main() installs its handlers: same exit code, no traceback
    sys.stderr.write("wbc: interrupted (Ctrl-C) while loading\n")
    sys.exit(130)


def _forget_caught_interrupt() -> None:
    """Clear CPython's record of a KeyboardInterrupt that left code run by ``PyRun_String`` (as an extension's
    ``exec`` does) and was then caught: under ``python -m`` CPython 3.11 keeps that record and, once the interpreter
    has finalized, ends the process by SIGINT whatever exit code :func:`main` returned (``Modules/main.c``:
    ``Py_RunMain`` after ``pymain_run_module``; a script run is not affected). A Ctrl-C landing in such a frame
    turned ``wbc ros2 node``'s 130 into −2. ``PyRun_String`` resets the record when it starts, so one harmless call
    clears it."""
    try:
        import ctypes

        run = ctypes.pythonapi.PyRun_String
    except (ImportError, AttributeError):  # not CPython
        return
    run.restype = ctypes.py_object
    run.argtypes = [ctypes.c_char_p, ctypes.c_int, ctypes.py_object, ctypes.py_object]
    scope: dict = {}
    run(b"None", 258, scope, scope)  # 258: Py_eval_input


try:
    code = main()
finally:  # also when main() exits by SystemExit (argparse: --help, --version, a bad option)
    _forget_caught_interrupt()
sys.exit(code)
