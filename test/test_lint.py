"""Lint as a test, as ament packages do: flake8 at ROS 2's 99 columns (setup.cfg)."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_flake8_finds_nothing():
    """Every Python file of the package, its tests and setup.py passes flake8."""
    result = subprocess.run([sys.executable, '-m', 'flake8', 'rigid_sim', 'test', 'setup.py'],
                            cwd=ROOT, capture_output=True, text=True, check=False)
    assert result.returncode == 0, result.stdout + result.stderr
