"""The code stays runnable on Python 3.8, ROS Noetic's (Ubuntu 20.04), though it is developed on
3.11: vermin (installed into the venv by ./run) reads every Python file of the repository and
fails when one needs a newer Python (a `match`, `str.removeprefix`, `dict | dict`, `list[int]` at
run time, ...)."""

import os
import shutil
import subprocess
import sys

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
FOLDERS = ('src', 'scripts', 'test', 'bench', 'examples')
TARGET = '3.8-'


def vermin(*paths):
    exe = shutil.which('vermin') or os.path.join(os.path.dirname(sys.executable), 'vermin')
    assert os.path.exists(exe), 'vermin is not installed in this Python\'s environment (./run installs it)'
    return subprocess.run([exe, '--no-tips', '--no-parse-comments', '-t=' + TARGET] + list(paths),
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, universal_newlines=True, timeout=120)


def test_every_python_file_runs_on_python_3_8():
    result = vermin(*(os.path.join(REPO, f) for f in FOLDERS))
    assert result.returncode == 0, 'needs a newer Python than 3.8:\n%s' % result.stdout


def test_the_check_catches_newer_syntax(tmp_path):
    newer = tmp_path / 'newer.py'
    newer.write_text('def f(x):\n    return {} | {} if x.removeprefix("a") else None\n')
    result = vermin(str(newer))
    assert result.returncode != 0 and '3.9' in result.stdout, result.stdout
