"""What the arm studies (study_arm6.py, study_parol6.py) share: the project's root, its command,
and the `size` table's reader. Each study calls the one C++ experiment through `mjstepper`."""

import csv
import os
import re
import subprocess
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.path.join(ROOT, "build", "mjstepper")


def cli(args):
    """Runs `mjstepper ARGS` from the root (no shell); its stdout, or exits with its stderr."""
    result = subprocess.run([CLI] + args, cwd=ROOT, capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"mjstepper {' '.join(args)} failed:\n{result.stderr}")
    return result.stdout


def move_args(poses):
    """`--move JOINT=A,B,...deg` for each joint's poses (degrees)."""
    args = []
    for joint, angles in poses.items():
        args += ["--move", f"{joint}=" + ",".join(str(a) for a in angles) + "deg"]
    return args


def read_table(path):
    """A `size` table (PREFIX.csv): joint → its row."""
    with open(path, newline="") as f:
        return {row["joint"]: row for row in csv.DictReader(f)}


def run_conditions(*models):
    """The sentence a study's page gives on how it simulated (issue 30, item 6): per model file,
    its timestep and its steppers' coupling and fidelity, the plugin's defaults (`consistent`,
    `switching`) where the file sets none."""
    parts = []
    for path in models:
        with open(path if os.path.isabs(path) else os.path.join(ROOT, path)) as f:
            xml = f.read()
        step = re.search(r'<option[^>]*\btimestep="([^"]+)"', xml)
        couplings = (sorted(set(re.findall(r'<config key="coupling" value="([^"]+)"', xml)))
                     or ["consistent"])
        fidelities = (sorted(set(re.findall(r'<config key="fidelity" value="([^"]+)"', xml)))
                      or ["switching"])
        name = os.path.relpath(path, ROOT) if os.path.isabs(path) else path
        parts.append(f"`{name}` at {float(step.group(1)) if step else 0.002:g} s, coupling "
                     f"{'/'.join(couplings)}, fidelity {'/'.join(fidelities)}")
    return ("Simulated with: " + "; ".join(parts) + " (`docs/coupling.md` measures each mode "
            "against finer steps).")
