"""The bench scripts' shared venv (bench/.venv): created on first use, topped up with any
package a script needs that is missing, then the script re-runs itself inside it."""
import os, subprocess, sys, venv

HERE = os.path.dirname(os.path.abspath(__file__))
VENV = os.path.join(HERE, ".venv")


def ensure_venv(packages, modules):
    """Re-executes the calling script inside bench/.venv, installing `packages` (pip names)
    when one of `modules` (import names) is missing there."""
    if sys.prefix == VENV:
        return
    py = os.path.join(VENV, "bin", "python")
    if not os.path.exists(py):
        venv.create(VENV, with_pip=True)
    probe = subprocess.run([py, "-c", "import " + ", ".join(modules)], capture_output=True)
    if probe.returncode != 0:
        subprocess.check_call([py, "-m", "pip", "install", "-q", *packages])
    os.execv(py, [py] + sys.argv)
