"""The default study's first part (bash scripts/study.sh, the main job): the Tsui rigid-load ramp
0 → 200 r/min in 0.8 s (Tsui 2009 Fig. 7 conditions) on two identical motors side by side
(models/tsui_pair.xml), one undamped and one with all three detent harmonics compensated (T(13)).
Writes
  logs/study_ramp.csv                  every signal of both motors, every 50 µs step
  renders/study_ramp.mp4               side-by-side video, 10× slow motion, with overlays
  renders/study_velocity_error.png     both velocity errors against commanded speed
  renders/study_ramp.png               both runs' signals against time
from the mjstepper command, run from the clone's root (so no machine's path reaches a figure).

    .venv/bin/python src/tools/python/study_ramp.py      (bash scripts/study.sh runs it)
"""
import os
import subprocess

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..", ".."))
CLI = os.path.join(ROOT, "build", "mjstepper")
RAMP = "ramp(0rpm,200rpm,0.8s)"


def mjstepper(*args):
    subprocess.run([CLI, *args], cwd=ROOT, check=True)


def main():
    mjstepper("info", "models/tsui_pair.xml")
    mjstepper("run", "models/tsui_pair.xml", "--duration", "0.8", "--ctrl", f"undamped={RAMP}",
              "--ctrl", f"damped={RAMP}", "--log", "logs/study_ramp.csv", "--plot",
              "renders/study_ramp.png", "--render", "renders/study_ramp.mp4", "--camera", "front",
              "--size", "1280x720", "--fps", "30", "--playback", "0.1")
    mjstepper("plot", "logs/study_ramp.csv", "--versus-speed", "--out",
              "renders/study_velocity_error.png", "--title",
              "Tsui ramp 0-200 r/min: velocity error, undamped vs all three harmonics damped")


if __name__ == "__main__":
    main()
