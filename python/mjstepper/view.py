"""MuJoCo's viewer with live plots of a stepper: `python -m mjstepper.view MODEL [--stepper NAME]`.

The model runs in real time in mujoco.viewer (launch_passive). Beside the scene, three live plots
of the selected stepper over the last few seconds: its speed against the command (r/min), its
phase currents (A) and its load angle (electrical rad), with its drive, lost steps and temperature
in a line of text. The stepper's command is the "Control" slider of the viewer's right panel (its
range set here when the model gives none: ±600 r/min on a velocity input, ±2 turns on a position
input, ±2 turns of microsteps on a STEP/DIR input). Double-click a body to plot the stepper that
drives its joint; --stepper picks one at the start.
"""
import argparse
import collections
import json
import math
import os
import stat
import sys
import tempfile
import threading
import time

import mujoco
import mujoco.viewer
import numpy as np

from . import ATTRIBUTES, PLUGIN_NAME, SIGNALS, add_signal_sensors

RPM = 60 / (2 * math.pi)
_DEFAULT_INPUT = "position"  # the plugin's default `input` (plugin/README.md)
assert "input" in ATTRIBUTES


def _stepper_actuators(spec):
    """The spec's stepper actuators (by the plugin's name, or a named instance of it)."""
    instances = {p.name: p.plugin_name for p in spec.plugins}
    return [a for a in spec.actuators if a.plugin.active and
            (a.plugin.plugin_name or instances.get(a.plugin.name, "")) == PLUGIN_NAME]


def _config(spec, actuator):
    if actuator.plugin.plugin_name:
        return dict(actuator.plugin.config)
    return dict(next(p for p in spec.plugins if p.name == actuator.plugin.name).config)


def _microsteps(config):
    """`microsteps` read as the plugin reads it, a number (`1e2` is 100; int() raised a
    ValueError, issue 33). A text the plugin refuses is left to its own message when the model
    compiles: the slider takes 16 meanwhile."""
    try:
        value = float(config.get("microsteps") or 16)
    except ValueError:
        return 16
    return int(value) if math.isfinite(value) and value >= 1 else 16


def _slider_range(config):
    """The command's slider range for a stepper's input mode (ctrl's unit)."""
    mode = config.get("input", _DEFAULT_INPUT)
    if mode == "velocity":
        return (-600 / RPM, 600 / RPM)  # rad/s
    if mode == "steps":
        microsteps = _microsteps(config)
        return (-2 * 200 * microsteps, 2 * 200 * microsteps)  # microsteps
    return (-4 * math.pi, 4 * math.pi)  # rad


def load(path):
    """The compiled model with a signal sensor on every stepper and a slider range on each; the
    steppers' names."""
    spec = mujoco.MjSpec.from_file(path)
    steppers = _stepper_actuators(spec)
    if not steppers:
        raise SystemExit(f"{path}: no {PLUGIN_NAME} actuator to plot")
    for a in steppers:
        if not a.name:
            raise SystemExit(f"{path}: a stepper actuator has no name; name it to plot it")
        if a.ctrllimited != mujoco.mjtLimited.mjLIMITED_TRUE:
            a.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
            a.ctrlrange = _slider_range(_config(spec, a))
    add_signal_sensors(spec)
    return spec.compile(), [a.name for a in steppers]


class Plots:
    """Live figures of one stepper's signals, kept for the last `window` seconds."""

    PANELS = (("speed (r/min)", ("rotor", "command")),
              ("phase currents (A)", ("i_a", "i_b")),
              ("load angle (electrical rad)", ("delta",)))
    COLOURS = ((1.0, 0.85, 0.1), (0.2, 0.9, 1.0), (1.0, 0.35, 0.35))

    def __init__(self, model, window=2.0, points=500):
        self.model = model
        self.window = window
        self.points = points
        self.history = collections.deque()
        self.figures = []
        for title, lines in self.PANELS:
            fig = mujoco.MjvFigure()
            mujoco.mjv_defaultFigure(fig)
            fig.title = title
            fig.xlabel = "s"
            fig.flg_extend = 1
            fig.figurergba[3] = 0.6
            fig.gridsize = [3, 3]
            fig.linewidth = 2.5
            for k, name in enumerate(lines):
                fig.linename[k] = name
                fig.linergb[k] = self.COLOURS[k]
            self.figures.append(fig)

    def sample(self, data, actuator, sensor_adr):
        s = data.sensordata[sensor_adr:sensor_adr + len(SIGNALS)]
        get = dict(zip(SIGNALS, s))
        speed = data.actuator_velocity[self.model.actuator_outadr[actuator]]  # rad/s
        self.history.append((data.time, speed * RPM,
                             get["omega_cmd"] * RPM, get["current_a"], get["current_b"],
                             get["load_angle"]))
        while self.history and self.history[0][0] < data.time - self.window:
            self.history.popleft()

    def update(self):
        rows = np.array(self.history) if self.history else np.zeros((0, 6))
        step = max(1, len(rows) // self.points)
        rows = rows[::-step][::-1]  # the newest sample always drawn
        column = 1
        for fig, (_, lines) in zip(self.figures, self.PANELS):
            for k in range(len(lines)):
                n = len(rows)
                fig.linepnt[k] = n
                if n:
                    fig.linedata[k][0:2 * n:2] = rows[:, 0]
                    fig.linedata[k][1:2 * n:2] = rows[:, column]
                column += 1
        return len(rows)

    def layout(self, viewport):
        """(viewport, figure) pairs: the figures stacked at the scene's right edge."""
        width = min(viewport.width, max(240, viewport.width // 3))
        height = max(100, viewport.height // 4)
        left = viewport.left + viewport.width - width
        return [(mujoco.MjrRect(left, viewport.bottom + k * height, width, height), fig)
                for k, fig in enumerate(reversed(self.figures))]


def _report_problem(path):
    """Why `path` cannot take the report, or None: checked before any window opens (issue 33: a
    directory, /dev/null, a link or a missing folder made the view hang or crash at its end)."""
    if path == "":
        return "an empty path"
    if os.path.lexists(path) and not stat.S_ISREG(os.lstat(path).st_mode):
        return "not a regular file (a folder, link, FIFO or device); outputs replace only those"
    folder = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(folder):
        return f"its folder {folder} does not exist"
    if not os.access(folder, os.W_OK | os.X_OK):
        return f"its folder {folder} is not writable"
    return None


def _write_whole(path, summary):
    """JSON into a new temporary beside `path`, renamed over it: never half-written, and only ever
    replacing a regular file (a link, FIFO or device is refused, as by the command)."""
    if _report_problem(path) is not None:
        raise SystemExit(f"--report {path}: {_report_problem(path)}")
    fd, temporary = tempfile.mkstemp(dir=os.path.dirname(os.path.abspath(path)), suffix=".tmp")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(summary, f)
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def main(argv=None):
    parser = argparse.ArgumentParser(prog="python -m mjstepper.view", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("model", help="MJCF model with mjstepper actuators")
    parser.add_argument("--stepper", help="the stepper plotted first (default: the first)")
    parser.add_argument("--ctrl", type=float, help="the command's start value (ctrl's unit)")
    parser.add_argument("--window", type=float, default=2.0, help="s of history in the plots")
    parser.add_argument("--duration", type=float,
                        help="close after this much simulated time, s (default: when closed)")
    parser.add_argument("--report", help="write a JSON summary here when done (tests)")
    parser.add_argument("--no-plots", action="store_true", help="the viewer alone")
    args = parser.parse_args(argv)
    if not 0.1 <= args.window <= 60:
        parser.error(f"--window {args.window}: must be in [0.1, 60] s")
    if args.duration is not None and not 0 < args.duration <= 1e6:
        parser.error(f"--duration {args.duration}: must be in (0, 1e6] s")
    if args.report is not None and _report_problem(args.report) is not None:
        parser.error(f"--report {args.report}: {_report_problem(args.report)}")

    model, names = load(args.model)
    if args.stepper is not None and args.stepper not in names:
        parser.error(f"--stepper {args.stepper}: not a stepper of {args.model} "
                     f"(steppers: {', '.join(names)})")
    data = mujoco.MjData(model)
    ids = {n: mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, n) for n in names}
    sensor_of = {}
    for s in range(model.nsensor):
        if (model.sensor_type[s] == mujoco.mjtSensor.mjSENS_PLUGIN
                and model.sensor_objtype[s] == mujoco.mjtObj.mjOBJ_ACTUATOR):
            sensor_of[int(model.sensor_objid[s])] = int(model.sensor_adr[s])
    body_of = {}  # the body whose joint a stepper drives: a double-click there selects it
    for n, a in ids.items():
        if model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT:
            body_of.setdefault(int(model.jnt_bodyid[model.actuator_trnid[a, 0]]), n)
    current = args.stepper or names[0]
    if args.ctrl is not None:
        lo, hi = model.actuator_ctrlrange[ids[current]]
        if not lo <= args.ctrl <= hi:
            parser.error(f"--ctrl {args.ctrl}: outside the slider's range [{lo:g}, {hi:g}]")
        data.ctrl[model.actuator_ctrladr[ids[current]]] = args.ctrl
    mujoco.mj_forward(model, data)
    plots = Plots(model, args.window)
    drawn = 0
    before = set(threading.enumerate())
    with mujoco.viewer.launch_passive(model, data) as viewer:
        render = [t for t in threading.enumerate() if t not in before]  # the viewer's own thread
        start_wall, start_sim = time.monotonic(), data.time
        while viewer.is_running():
            if render and not any(t.is_alive() for t in render):
                break  # its window is gone without a close (the render thread ended)
            if args.duration is not None and data.time >= args.duration:
                break
            selected = int(viewer.perturb.select)
            if selected in body_of and body_of[selected] != current:
                current = body_of[selected]
                plots = Plots(model, args.window)
            a = ids[current]
            with viewer.lock():
                target = start_sim + (time.monotonic() - start_wall)
                steps = 0
                while data.time < target and steps < 20000:  # never more than a frame's worth
                    mujoco.mj_step(model, data)
                    plots.sample(data, a, sensor_of[a])
                    steps += 1
                if steps == 20000:  # slower than real time: let the clock follow the model
                    start_wall, start_sim = time.monotonic(), data.time
                s = data.sensordata[sensor_of[a]:sensor_of[a] + len(SIGNALS)]
                get = dict(zip(SIGNALS, s))
                texts = (mujoco.mjtFontScale.mjFONTSCALE_150, mujoco.mjtGridPos.mjGRID_TOPLEFT,
                         f"stepper {current}\ncommand (slider)\nlost steps\nwinding",
                         f"{len(names)} in the model\n"
                         f"{data.ctrl[model.actuator_ctrladr[a]]:.4g}\n"
                         f"{get['lost_steps']:g}\n{get['winding_temperature']:.1f} C")
            # Outside the lock: set_texts and set_figures wait for the render thread to take them,
            # and the render thread waits for the lock (with it held, the view hung at random,
            # spinning a core).
            viewer.set_texts(texts)
            if not args.no_plots and viewer.viewport is not None:
                drawn = plots.update()
                viewer.set_figures(plots.layout(viewer.viewport))
            viewer.sync()
            time.sleep(1 / 60)
        failure = None
        if args.report:
            a = ids[current]
            try:
                _write_whole(args.report, {
                    "stepper": current, "time": data.time,
                    "ctrl": float(data.ctrl[model.actuator_ctrladr[a]]),
                    "ctrlrange": [float(x) for x in model.actuator_ctrlrange[a]],
                    "speed": float(data.actuator_velocity[model.actuator_outadr[a]]),
                    "mean_speed": float(np.mean([h[1] for h in plots.history
                                                 if h[0] >= data.time - 0.5]) / RPM),
                    "plotted_points": drawn})
            except (OSError, SystemExit) as e:  # (the folder changed under the view)
                failure = f"--report {args.report}: {e}"
            else:
                time.sleep(float(os.environ.get("MJSTEPPER_VIEW_HOLD", "0")))  # a screenshot
    # close() only asks the viewer's (daemon) thread to stop: wait until it has destroyed its
    # window, or it may still be doing so when glfw.terminate runs at exit (a segfault in GLFW).
    # It takes milliseconds; one that has not within a second (its X server gone, a GL driver
    # stuck) is left behind by a hard exit, the report already whole on disk: every exit path
    # returns within a second (issue 33).
    status = 0 if failure is None else 1
    if failure is not None:
        print(failure, file=sys.stderr)
    deadline = time.monotonic() + 1.0
    for thread in threading.enumerate():
        if thread is not threading.main_thread() and thread.daemon:
            thread.join(timeout=max(0.0, deadline - time.monotonic()))
            if thread.is_alive():
                sys.stderr.flush()
                os._exit(status)
    return status


if __name__ == "__main__":
    sys.exit(main())
