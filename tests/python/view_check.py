"""`python -m mjstepper.view` on a virtual X screen (run under xvfb-run by wheel_test.sh, in the
wheel's venv): the viewer runs the model in real time with the stepper's command on a slider (the
actuator's ctrlrange, set by the view), and live plots of its signals, whose first line's yellow
appears on the screen only with the plots.
    view_check.py SOURCE_DIR"""
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import unittest

from xscreen import count_pixels, grab_screen

SOURCE = sys.argv[1]


def view(*args):
    """Runs the view for 1.5 s of simulated time; (its report, yellow pixels on the right)."""
    report = os.path.join(tempfile.mkdtemp(), "view.json")
    process = subprocess.Popen(
        [sys.executable, "-m", "mjstepper.view", os.path.join(SOURCE, "models", "tsui_rigid.xml"),
         "--duration", "1.5", "--report", report, *args],
        env={**os.environ, "MJSTEPPER_VIEW_HOLD": "4"})
    deadline = time.monotonic() + 120
    while not os.path.exists(report) and time.monotonic() < deadline and process.poll() is None:
        time.sleep(0.2)
    time.sleep(1.0)  # the render thread draws the last state
    screen = grab_screen() if process.poll() is None else None
    status = process.wait(timeout=120)
    assert status == 0, f"the view exited with {status}"
    with open(report) as f:
        summary = json.load(f)
    # The speed plot's rotor line, (1, 0.85, 0.1) = (255, 217, 26); the viewer's own yellow text is
    # (255, 255, 0)-like and falls outside.
    yellow = count_pixels(screen, lambda r, g, b: r >= 245 and 200 <= g <= 235 and b <= 45, step=1)
    return summary, yellow


class View(unittest.TestCase):
    def test_live_plots_and_the_command_slider(self):
        summary, yellow = view("--ctrl", "20")
        self.assertEqual(summary["stepper"], "shaft")
        # The slider: the velocity input's ±600 r/min, holding the command given.
        self.assertAlmostEqual(summary["ctrlrange"][1], 600 * 2 * math.pi / 60, places=9)
        self.assertEqual(summary["ctrl"], 20.0)
        self.assertGreaterEqual(summary["time"], 1.5)
        # rad/s: the rotor follows, on average over the last 0.5 s (its ripple is ±2 rad/s here)
        self.assertAlmostEqual(summary["mean_speed"], 20.0, delta=0.2)
        self.assertGreater(summary["plotted_points"], 100)
        _, without = view("--ctrl", "20", "--no-plots")
        self.assertGreater(yellow, 200)  # the line: about 700 pixels at 640×480
        self.assertLess(without, 5)

    def test_a_bad_report_is_refused_before_any_window(self):
        # Issue 33: a directory, /dev/null, a link or a missing folder as --report made the view
        # hang (11 of 19 runs), crash (5) or fail only at its end.
        model = os.path.join(SOURCE, "models", "tsui_rigid.xml")
        folder = tempfile.mkdtemp()
        link = os.path.join(folder, "link.json")
        os.symlink(os.path.join(folder, "elsewhere.json"), link)
        for report, words in ((folder, "not a regular file"), ("/dev/null", "not a regular file"),
                              (link, "not a regular file"),
                              (os.path.join(folder, "missing", "r.json"), "does not exist")):
            start = time.monotonic()
            result = subprocess.run([sys.executable, "-m", "mjstepper.view", model, "--duration",
                                     "0.2", "--report", report],
                                    capture_output=True, text=True, timeout=60)
            self.assertEqual(result.returncode, 2, result.stderr)
            self.assertIn(f"--report {report}: ", result.stderr)
            self.assertIn(words, result.stderr)
            self.assertLess(time.monotonic() - start, 20)  # no window was opened: an import's time
        self.assertFalse(os.path.exists(os.path.join(folder, "elsewhere.json")))

    def test_the_view_exits_when_its_x_server_goes(self):
        # Issue 33: a view outlived its test by 40 minutes, its X server gone. Its own Xvfb here,
        # killed under it: the view exits within seconds, whatever its status.
        number = 100 + os.getpid() % 400
        socket = f"/tmp/.X11-unix/X{number}"
        xvfb = subprocess.Popen(["Xvfb", f":{number}", "-screen", "0", "640x480x24"],
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        view = None
        try:
            deadline = time.monotonic() + 20
            while not os.path.exists(socket) and time.monotonic() < deadline:
                time.sleep(0.1)
            self.assertTrue(os.path.exists(socket), "Xvfb did not start")
            view = subprocess.Popen(
                [sys.executable, "-m", "mjstepper.view",
                 os.path.join(SOURCE, "models", "tsui_rigid.xml")],
                env={**os.environ, "DISPLAY": f":{number}"}, stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL)
            time.sleep(5)  # its window up, stepping in real time
            self.assertIsNone(view.poll(), "the view ended before its X server did")
            xvfb.kill()
            xvfb.wait(timeout=10)
            view.wait(timeout=10)  # TimeoutExpired: it outlived its X server
        finally:
            for process in (view, xvfb):
                if process is not None and process.poll() is None:
                    process.kill()
                    process.wait()

    def test_bounds_are_named_before_any_window(self):
        model = os.path.join(SOURCE, "models", "tsui_rigid.xml")
        for args, words in ((["--duration", "-1"], "--duration -1.0: must be in (0, 1e6] s"),
                            (["--window", "100"], "--window 100.0: must be in [0.1, 60] s"),
                            (["--stepper", "nothing"], "--stepper nothing: not a stepper")):
            result = subprocess.run([sys.executable, "-m", "mjstepper.view", model, *args],
                                    capture_output=True, text=True, timeout=60)
            self.assertNotEqual(result.returncode, 0)
            self.assertIn(words, result.stderr)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
