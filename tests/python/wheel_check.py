"""Run inside a fresh virtual environment where only the mjstepper wheel (and what it requires) is
installed: import, signals by name, presets, the libraries' run-time needs, the version check, the
command, the experiments against the command's to the bit (Python and Ray), and the checks of
every argument (issue 16)."""
import csv
import math
import os
import stat
import subprocess
import sys
import tempfile
import unittest
from unittest import mock

import mujoco
import numpy as np

import mjstepper
import mjstepper.distributed

SOURCE = sys.argv[1]
CLI = sys.argv[2]  # the build tree's mjstepper command
MJSTEPPER = os.path.join(os.path.dirname(sys.executable), "mjstepper")  # the wheel's
RIGID = os.path.join(SOURCE, "models", "tsui_rigid.xml")
COUPLING = os.path.join(SOURCE, "models", "tsui_coupling.xml")


class WheelInAFreshEnvironment(unittest.TestCase):
    def test_steps_a_model_and_reads_signals_by_name(self):
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        self.assertEqual(mjstepper.add_signal_sensors(spec), ["shaft"])
        self.assertEqual(mjstepper.add_signal_sensors(spec), [])  # once only
        model = spec.compile()
        data = mujoco.MjData(model)
        omega = 100 * 2 * math.pi / 60  # rad/s
        for _ in range(4000):  # 0.2 s at 100 r/min (velocity input)
            data.ctrl[0] = omega
            mujoco.mj_step(model, data)
        signals = mjstepper.signals(model, data, "shaft")
        self.assertEqual(tuple(signals), mjstepper.SIGNALS)
        self.assertAlmostEqual(data.qpos[0] / (omega * 0.2), 1.0, delta=0.02)
        current_a, unit = signals["current_a"]
        self.assertEqual(unit, "A")
        magnitude = math.hypot(current_a, signals["current_b"][0])
        self.assertAlmostEqual(magnitude, 1.9, delta=0.19)  # the PI loop's 1.9 A (ripple, lag)
        self.assertEqual(signals["lost_steps"], (0.0, "full steps"))
        with self.assertRaises(KeyError):
            mjstepper.signals(model, data, "no_such_actuator")

    def test_config_edited_through_mjspec(self):
        """mjstepper.configure edits the spec's plugin config: the drive holds 1.5 A instead of
        the default 1.9 A, and a bad value fails to compile, naming it."""
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        mjstepper.add_signal_sensors(spec)
        mjstepper.configure(spec, "shaft", hold_current=1.5)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        self.assertAlmostEqual(mjstepper.signals(model, data, "shaft")["current_d"][0], 1.5,
                               delta=1e-12)
        mjstepper.configure(spec, "shaft", hold_current=-1)
        with self.assertRaises(ValueError) as ctx:
            spec.compile()
        self.assertIn('hold_current = "-1"', str(ctx.exception))

    def test_step_time_list_drives_a_stepping_stepper(self):
        """Issue 17: a motion controller's step times (mjstepper.StepTimes, the command line's
        steps(FILE) format) drive a chopper with input=steps; the drive's commanded angle is the
        list's count of microsteps; a bad list names its file and line."""
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        mjstepper.add_signal_sensors(spec)
        mjstepper.configure(spec, "shaft", drive="chopper", input="steps", bus_voltage=24,
                            run_current=1.3)
        model = spec.compile()
        data = mujoco.MjData(model)
        path = os.path.join(tempfile.mkdtemp(), "moves.txt")
        with open(path, "w") as f:
            f.write("# 400 microsteps forward at 8 kHz, 80 back\n")
            f.writelines(f"{k * 125e-6}\n" for k in range(1, 401))
            f.writelines(f"{0.05 + k * 125e-6} -1\n" for k in range(1, 81))
        steps = mjstepper.StepTimes.read(path)
        self.assertEqual(steps.count(0.05), 400)
        while data.time < steps.last_time + 0.005:
            data.ctrl[0] = steps.count(data.time + model.opt.timestep)
            mujoco.mj_step(model, data)
        step = 2 * math.pi / (4 * 50 * 16)  # rad per microstep
        self.assertAlmostEqual(mjstepper.signals(model, data, "shaft")["theta_cmd"][0],
                               320 * step, delta=1e-12)
        with open(path, "a") as f:
            f.write("0.01\n")
        with self.assertRaises(ValueError) as ctx:
            mjstepper.StepTimes.read(path)
        self.assertIn("moves.txt:482", str(ctx.exception))
        self.assertIn("must not decrease", str(ctx.exception))

    def test_presets_with_units(self):
        tsui = mjstepper.PRESETS["tsui2009"]
        self.assertEqual(tsui["rotor_inertia"], (0.36e-4, "kg·m²"))
        self.assertEqual(tsui["rated_current"], (3.0, "A"))
        self.assertEqual(set(mjstepper.PRESETS),
                         {"tsui2009", "kim2016", "bodson1993",  # the papers (SPEC §4)
                          "qsh4218_35", "qsh4218_41", "qsh4218_51", "qsh5718_51", "qsh5718_76",
                          "17hm19_2004s", "17hs19_2004s1",  # catalogue motors (SPEC §8)
                          "17hs24_2104s", "17hs16_2004s1", "17hs08_1004s"})  # PAROL6's (§12)
        # A catalogue motor's Km comes from its datasheet: T_H/(√2·I_r), QSH5718-76 1.89 N·m, 2.8 A.
        self.assertAlmostEqual(mjstepper.PRESETS["qsh5718_76"]["torque_constant"][0],
                               1.89 / (2 ** 0.5 * 2.8), places=12)

    def test_library_needs_only_mujoco_from_the_package(self):
        dynamic = subprocess.run(["readelf", "-d", mjstepper.LIBRARY], capture_output=True,
                                 text=True, check=True).stdout
        self.assertIn("[$ORIGIN/../mujoco]", dynamic)  # RUNPATH: the installed mujoco package
        needed = [line.split("[")[1].rstrip("]") for line in dynamic.splitlines()
                  if "(NEEDED)" in line]
        self.assertIn(f"libmujoco.so.{mujoco.__version__}", needed)
        runtimes = ("libmujoco", "libfmt", "libstdc++", "libm.", "libgcc_s", "libc.", "ld-linux")
        for library in needed:  # C and C++ runtimes, MuJoCo and Debian's fmt: nothing else
            self.assertTrue(library.startswith(runtimes), library)
        # The engine (the command and the experiments) needs Debian's tinyxml2 and libpng besides
        # (README, "The Python package"), and loads OSMesa only to render.
        engine = os.path.join(os.path.dirname(mjstepper.LIBRARY),
                              next(f for f in os.listdir(os.path.dirname(mjstepper.LIBRARY))
                                   if f.startswith("_engine")))
        dynamic = subprocess.run(["readelf", "-d", engine], capture_output=True, text=True,
                                 check=True).stdout
        needed = [line.split("[")[1].rstrip("]") for line in dynamic.splitlines()
                  if "(NEEDED)" in line]
        self.assertIn(f"libmujoco.so.{mujoco.__version__}", needed)
        for library in needed:
            self.assertTrue(library.startswith(runtimes + ("libtinyxml2", "libpng16", "libz")),
                            library)

    def test_refuses_another_mujoco_naming_both_versions(self):
        code = "import mujoco; mujoco.__version__ = '3.9.9'; import mjstepper"
        result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        self.assertNotEqual(result.returncode, 0)
        self.assertIn("3.9.9", result.stderr)
        self.assertIn(mujoco.__version__, result.stderr)


def read(path):
    with open(path, "rb") as f:
        return f.read()


def csv_column(path, name):
    """A CSV column as floats (17 digits: each the double written, exactly)."""
    with open(path) as f:
        rows = list(csv.reader(f))
    k = rows[0].index(name)
    return [float(row[k]) for row in rows[1:]]


class TheCommand(unittest.TestCase):
    """Issue 19 item 2: `pip install` gives the `mjstepper` command, every subcommand."""

    def command(self, *args, env=None):
        return subprocess.run([MJSTEPPER, *args], capture_output=True, text=True,
                              env={**os.environ, **(env or {})})

    def test_every_subcommand_is_there(self):
        self.assertEqual(os.path.dirname(MJSTEPPER), os.path.dirname(sys.executable))
        result = self.command("--help")
        self.assertEqual(result.returncode, 0, result.stderr)
        for sub in ("run", "sweep", "map", "pullout", "identify", "resonance-test", "size",
                    "attach", "plot", "info", "tables"):
            self.assertIn(sub, result.stdout)
        info = self.command("info", RIGID)
        self.assertEqual(info.returncode, 0, info.stderr)
        self.assertIn("T(1) = 28.5 N·m/rad", info.stdout)
        module = subprocess.run([sys.executable, "-m", "mjstepper", "info", RIGID],
                                capture_output=True, text=True)
        self.assertEqual(module.stdout, info.stdout)
        bad = self.command("sweep", RIGID, "--speeds", "40rpm", "--settle", "-1", "--out", "x")
        self.assertNotEqual(bad.returncode, 0)
        self.assertIn("--settle", bad.stderr)

    def test_plots_with_the_packages_matplotlib_and_renders_with_osmesa(self):
        out = os.path.join(os.getcwd(), "command")
        result = self.command("run", RIGID, "--duration", "0.05", "--quiet", "--ctrl",
                              "shaft=constant(60rpm)", "--log", out + ".csv", "--plot",
                              out + ".png", "--render", out + ".mp4", "--size", "320x240",
                              "--fps", "20")
        self.assertEqual(result.returncode, 0, result.stderr)
        self.assertEqual(read(out + ".png")[:8], b"\x89PNG\r\n\x1a\n")
        self.assertGreater(os.path.getsize(out + ".mp4"), 1000)

    def test_render_without_osmesa_says_what_to_install(self):
        video = os.path.join(os.getcwd(), "no_osmesa.mp4")
        result = self.command("run", RIGID, "--duration", "0.05", "--quiet", "--render", video,
                              env={"MJSTEPPER_OSMESA": "libOSMesa-missing.so"})
        self.assertNotEqual(result.returncode, 0)
        self.assertIn("rendering needs OSMesa", result.stderr)
        self.assertIn("apt-get install libosmesa6", result.stderr)
        self.assertFalse(os.path.exists(video))
        # Everything else runs without it.
        result = self.command("run", RIGID, "--duration", "0.05", "--quiet",
                              env={"MJSTEPPER_OSMESA": "libOSMesa-missing.so"})
        self.assertEqual(result.returncode, 0, result.stderr)


class OneEngine(unittest.TestCase):
    """Issue 19 item 1: the command line (the build tree's and the wheel's), Python and Ray give
    the same results, to the bit, on the same inputs: the same files byte for byte, and the
    Tables' doubles equal to the CSVs' (written with 17 digits, which read back exactly)."""

    def cli(self, *args):
        for program in (CLI, MJSTEPPER):  # the build tree's command, and the wheel's
            result = subprocess.run([program, *args], capture_output=True, text=True)
            self.assertEqual(result.returncode, 0, result.stderr)
        return result

    def test_sweep(self):
        base = os.path.join(os.getcwd(), "sweep")
        self.cli("sweep", RIGID, "--speeds", "40,45,85,170rpm", "--settle", "0.2", "--measure",
                 "0.2", "--quiet", "--out", base + "_cli")
        table = mjstepper.sweep(RIGID, "40,45,85,170rpm", settle=0.2, measure=0.2,
                                out=base + "_py")
        self.assertEqual(read(base + "_py.csv"), read(base + "_cli.csv"))
        self.assertEqual(table.speed.tolist(), csv_column(base + "_cli.csv", "speed[rad/s]"))
        self.assertEqual(table.units["rms_error"], "rad/s")
        self.assertEqual(table.dominant_frequency.tolist(),
                         csv_column(base + "_cli.csv", "dominant_frequency[Hz]"))
        # Not a degenerate grid: the resonances ripple more than their neighbours.
        self.assertGreater(table.rms_error.max(), 2 * table.rms_error.min())
        import ray
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            on_ray = mjstepper.distributed.sweep(RIGID, table.speed, settle=0.2, measure=0.2,
                                                 out=base + "_ray", quiet=True)
        finally:
            ray.shutdown()
        self.assertEqual(read(base + "_ray.csv"), read(base + "_cli.csv"))
        for name in table.dtype.names:  # (NaN equal to NaN: a rotary axis's carriage_speed)
            np.testing.assert_array_equal(on_ray[name], table[name], name)
        self.assertFalse(os.path.exists(base + "_ray.csv.tmp"))

    def test_map(self):
        base = os.path.join(os.getcwd(), "map")
        self.cli("map", COUPLING, "--speeds", "40,85rpm", "--vary", "stiffness:coupling=20,50",
                 "--settle", "0.2", "--measure", "0.2", "--quiet", "--out", base + "_cli")
        vary = ("stiffness:coupling", [20, 50])
        table = mjstepper.map(COUPLING, "40,85rpm", vary, settle=0.2, measure=0.2,
                              out=base + "_py")
        self.assertEqual(read(base + "_py.csv"), read(base + "_cli.csv"))
        self.assertEqual(table.value.tolist(), [20, 20, 50, 50])
        self.assertEqual(table.parameter, "stiffness:coupling")
        import ray
        ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
        try:
            on_ray = mjstepper.distributed.map(COUPLING, "40,85rpm", vary, settle=0.2,
                                               measure=0.2, out=base + "_ray", quiet=True)
        finally:
            ray.shutdown()
        self.assertEqual(read(base + "_ray.csv"), read(base + "_cli.csv"))
        for name in table.dtype.names:  # (NaN equal to NaN: a rotary axis's carriage_speed)
            np.testing.assert_array_equal(on_ray[name], table[name], name)

    def test_pullout(self):
        base = os.path.join(os.getcwd(), "pullout")
        self.cli("pullout", RIGID, "--speeds", "100,600rpm", "--quiet", "--out", base + "_cli")
        table = mjstepper.pullout(RIGID, "100,600rpm", out=base + "_py")
        self.assertEqual(read(base + "_py.csv"), read(base + "_cli.csv"))
        self.assertEqual(table.torque.tolist(),
                         csv_column(base + "_cli.csv", "pull_out_torque[N·m]"))
        self.assertEqual(table.held_max.dtype, np.bool_)
        self.assertGreater(table.torque[0], 0.3)  # N·m: Km·I = 0.57 at low speed

    def test_a_linear_axis_speaks_millimetres(self):
        # models/belt_axis.xml declares its GT2 20-tooth pulley: 40 mm per turn (README, "Linear
        # axes"); 50 and 100 mm/s are 75 and 150 r/min at the rotor.
        belt = os.path.join(SOURCE, "models", "belt_axis.xml")
        table = mjstepper.sweep(belt, "50,100mm/s", settle=0.1, measure=0.1)
        np.testing.assert_allclose(table.carriage_speed, [0.05, 0.1], rtol=1e-12)
        np.testing.assert_allclose(table.speed, np.array([75, 150]) * 2 * np.pi / 60, rtol=1e-12)
        curve = mjstepper.pullout(belt, "100mm/s")
        np.testing.assert_allclose(curve.force, curve.torque * 2 * np.pi / 0.04, rtol=1e-12)
        self.assertTrue(np.isnan(mjstepper.sweep(RIGID, "60rpm", settle=0.1,
                                                 measure=0.1).carriage_speed[0]))
        with self.assertRaisesRegex(ValueError, "pulley_teeth"):
            mjstepper.sweep(RIGID, "50mm/s")

    def test_size(self):
        base = os.path.join(os.getcwd(), "size")
        rotor = os.path.join(SOURCE, "tests", "tools", "models", "size_rotor.xml")
        self.cli("size", rotor, "--move", "shaft=2rad", "--dwell", "0.1", "--cycles", "5",
                 "--pullout-points", "3", "--quiet", "--out", base + "_cli")
        sizing = mjstepper.size(rotor, {"shaft": [2.0]}, dwell=0.1, cycles=5, pullout_points=3,
                                out=base + "_py")
        for suffix in (".csv", "_shaft_demand.csv", "_shaft_pullout.csv"):
            self.assertEqual(read(base + "_py" + suffix), read(base + "_cli" + suffix), suffix)
        self.assertTrue(os.path.getsize(base + "_py_shaft.png") > 1000)
        self.assertEqual(sizing.table.joint.tolist(), ["shaft"])
        self.assertEqual(sizing.table.margin.tolist(), csv_column(base + "_cli.csv", "margin[1]"))
        self.assertEqual(sizing.table.units["winding_temperature_cycles"], "°C")
        self.assertEqual(sizing.demand["shaft"].torque.tolist(),
                         csv_column(base + "_cli_shaft_demand.csv", "torque[N·m]"))
        self.assertEqual(sizing.pullout["shaft"].torque.tolist(),
                         csv_column(base + "_cli_shaft_pullout.csv", "pull_out_torque[N·m]"))
        self.assertAlmostEqual(sizing.cycle_time, 0.6, places=9)
        with self.assertRaisesRegex(ValueError, "(?<!-)move shaft=20mm"):
            mjstepper.size(rotor, {"shaft": "20mm"})

    def test_run(self):
        base = os.path.join(os.getcwd(), "run")
        args = ["--duration", "0.3", "--ctrl", "shaft=ramp(0rpm,150rpm,0.3s)"]
        self.cli("run", RIGID, *args, "--quiet", "--log", base + "_cli.csv")
        result = mjstepper.run(RIGID, 0.3, ctrl={"shaft": "ramp(0rpm,150rpm,0.3s)"},
                               log=base + "_py.csv")
        self.assertEqual(read(base + "_py.csv"), read(base + "_cli.csv"))
        self.assertEqual(result.steps, 6000)
        self.assertEqual(result.steppers.name.tolist(), ["shaft"])
        trace = result.traces["shaft"]
        self.assertEqual(len(trace), 6000)
        self.assertEqual(trace.units["current_a"], "A")
        self.assertAlmostEqual(float(trace.omega_cmd[-1]), 150 * 2 * math.pi / 60 * (1 - 1 / 6000),
                               places=9)

    def test_step_times_refuse_what_the_command_refuses(self):
        # issue 33: count(nan) gave the final count; a broadcast 1e9-element view was copied
        # before the size check; read() took 1_0e-3, which the command's reader refuses: read() is
        # now that reader (one reader per format), files that are no regular ones included.
        steps = mjstepper.StepTimes([0.1, 0.2, 0.3])
        self.assertEqual(steps.count(0.25), 2)
        with self.assertRaisesRegex(ValueError, "NaN"):
            steps.count(float("nan"))
        with self.assertRaisesRegex(ValueError, "more than 10000000 steps"):
            mjstepper.StepTimes(np.broadcast_to(np.float64(0.5), (10**9,)))
        path = os.path.join(os.getcwd(), "underscore.txt")
        with open(path, "w") as f:
            f.write("0.001\n1_0e-3\n")
        with self.assertRaisesRegex(ValueError, "underscore.txt:2: .*a step time is a number"):
            mjstepper.StepTimes.read(path)
        with self.assertRaisesRegex(ValueError, "/dev/zero: not a regular file"):
            mjstepper.StepTimes.read("/dev/zero")

    def test_arguments_are_checked_and_messages_bounded(self):
        # issue 33, found by tests/fuzz/python_fuzz.py: a None or a number where a sequence
        # belongs raised Python's own unnamed TypeError; range(10**9) as speeds was listed item by
        # item (minutes); StepTimes(10**400) raised OverflowError; a message quoted a
        # million-character argument whole, the engine's as well as the package's.
        from mjstepper import _experiments as ex
        with self.assertRaisesRegex(TypeError, "speeds = None .NoneType.: speeds takes a list"):
            ex.sweep_args(RIGID, None)
        with self.assertRaisesRegex(ValueError, "speeds: 1000000000 values; at most 100000"):
            ex.sweep_args(RIGID, range(10 ** 9))
        with self.assertRaisesRegex(TypeError, "vary = 5 .int.: vary takes a list"):
            ex.map_args(RIGID, "10rpm", 5)
        with self.assertRaisesRegex(ValueError, "vary = .'a', 1, 2.: vary is .parameter, values."):
            ex.map_args(RIGID, "10rpm", ("a", 1, 2))
        with self.assertRaisesRegex(ValueError, "size = .1, 2, 3.: size is .width, height."):
            ex.run_args(RIGID, 1.0, size=(1, 2, 3))
        with self.assertRaisesRegex(ValueError, "times: not numbers a double holds"):
            mjstepper.StepTimes(10 ** 400)
        with self.assertRaisesRegex(TypeError, "times: a generator"):
            mjstepper.StepTimes(x for x in [0.1])
        huge = "x" * 1_000_000 + "\x1b[2J"
        for call in (lambda: mjstepper.run(RIGID, huge),
                     lambda: mjstepper.run(huge, 1.0),
                     lambda: mjstepper.sweep(RIGID, "10rpm", settle=[huge])):
            with self.assertRaises((TypeError, ValueError)) as caught:
                call()
            text = str(caught.exception)
            self.assertLess(len(text), 2100, text[:300])
            self.assertNotIn("\x1b", text)

    def test_a_bool_is_only_a_flag(self):
        # issue 33: run(model, True) gave --duration no value, and the command read "--quiet" as
        # it ('--duration: "--quiet" is not a finite number'); a flag takes only True or False.
        with self.assertRaisesRegex(TypeError, "duration = True .bool.: duration takes a number"):
            mjstepper.run(RIGID, True)
        with self.assertRaisesRegex(TypeError, "allow_coarse = 'yes' .str.: allow_coarse takes"):
            mjstepper.run(RIGID, 0.01, allow_coarse="yes")
        self.assertEqual(mjstepper.run(RIGID, 0.001, allow_coarse=False, traces=False).steps, 20)

    def test_the_view_reads_microsteps_as_the_plugin_does(self):
        # issue 33: microsteps="1e2", which the plugin takes as 100, raised a ValueError in the
        # view's int(); a text the plugin refuses leaves the slider at 16 (the plugin names it).
        from mjstepper import view
        self.assertEqual(view._slider_range({"input": "steps", "microsteps": "1e2"}),
                         (-40000, 40000))
        self.assertEqual(view._slider_range({"input": "steps", "microsteps": "many"}),
                         (-6400, 6400))

    def test_run_replays_a_klipper_print(self):
        # issue 31, item 6: run(klipper=MAP) is `run --klipper MAP`.
        corexy = os.path.join(SOURCE, "models", "corexy.xml")
        prints = os.path.join(SOURCE, "models", "prints", "square20", "mzv.map")
        base = os.path.join(os.getcwd(), "klipper")
        self.cli("run", corexy, "--duration", "0.3", "--klipper", prints, "--quiet", "--log",
                 base + "_cli.csv")
        result = mjstepper.run(corexy, 0.3, klipper=prints, log=base + "_py.csv", traces=False)
        self.assertEqual(read(base + "_py.csv"), read(base + "_cli.csv"))
        self.assertEqual(result.steppers.lost_steps.tolist(), [0, 0])

    def test_attach(self):
        # issue 29, item 2: the Python twin of `mjstepper attach`, on the test's two-link URDF.
        robot = os.path.join(SOURCE, "tests", "tools", "models", "two_link.urdf")
        out = os.path.join(os.getcwd(), "two_link_steppers.xml")
        result = mjstepper.attach(robot, {"yaw": {"motor": "17hs19_2004s1", "gear": 10},
                                          "pitch": {"motor": "17hs16_2004s1", "driver": "tmc5160",
                                                    "gear": 20, "ihold": 24}}, out)
        self.assertEqual(list(result["joints"]), ["yaw", "pitch"])
        model = mujoco.MjModel.from_xml_path(out)
        self.assertEqual(model.opt.timestep, result["timestep"])
        self.assertEqual(model.nu, 2)
        self.assertEqual(model.actuator_gear[1][0], 20)
        with self.assertRaisesRegex(ValueError, "no hinge or slide joint named 'elbow'"):
            mjstepper.attach(robot, {"elbow": {"motor": "17hs19_2004s1"}}, out)

    def test_run_starts_settled_or_aligned(self):
        # models/arm3.xml with 1.5 kg (issue 29, item 5): held once settled, slips when dropped.
        arm = os.path.join(SOURCE, "models", "arm3.xml")
        lost = {}
        for start in ("settled", "aligned"):
            result = mjstepper.run(arm, 0.3, mass={"payload": 1.5}, start=start, traces=False)
            lost[start] = float(abs(result.steppers.lost_steps).sum())
        self.assertEqual(lost["settled"], 0)
        self.assertGreater(lost["aligned"], 0)
        with self.assertRaisesRegex(ValueError, "(?<!-)start"):
            mjstepper.run(arm, 0.01, start="upright")

    def test_identify(self):
        bench = os.path.join(SOURCE, "models", "tsui_identify.xml")
        printed = self.cli("identify", bench, "--speeds", "10,30rpm").stdout
        identified = mjstepper.identify(bench, "10,30rpm")
        self.assertIn(f'<config key="damping_detent" value="{identified.damping_detent}"/>',
                      printed)
        self.assertEqual(identified.harmonics.order.tolist(), [4, 2, 1])

    def test_resonance_test(self):
        base = os.path.join(os.getcwd(), "resonance")
        printer = os.path.join(SOURCE, "models", "corexy.xml")
        args = ["--axis", "x", "--min-freq", "30", "--max-freq", "90", "--hz-per-sec", "6"]
        self.cli("resonance-test", printer, *args, "--quiet", "--out", base + "_cli")
        r = mjstepper.resonance_test(printer, "x", base + "_py", min_freq=30, max_freq=90,
                                     hz_per_sec=6)
        for suffix in ("_raw.csv", "_psd.csv"):
            self.assertEqual(read(base + "_py" + suffix), read(base + "_cli" + suffix), suffix)
        self.assertEqual(len(r.fits), 6)
        self.assertIn(r.recommended, r.fits.shaper.tolist())


def rigid_at_timestep(timestep, name):
    """models/tsui_rigid.xml at another timestep (s, as MJCF text), written to `name` in the
    working folder; its path."""
    with open(RIGID) as f:
        text = f.read().replace('timestep="5e-5"', f'timestep="{timestep}"')
    path = os.path.join(os.getcwd(), name)
    with open(path, "w") as f:
        f.write(text)
    return path


class Arguments(unittest.TestCase):
    """Every argument goes through the command's own parser and checks (issue 16): a bad one is
    refused before any work, naming the option, its value and its bound."""

    def assertRejects(self, error, words, function=None, *args, **options):
        with mock.patch.dict(sys.modules, {"ray": None}):  # a run would need Ray: none starts
            with self.assertRaises(error) as ctx:
                (function or mjstepper.sweep)(*args, **options)
        for word in words:
            self.assertIn(word, str(ctx.exception))

    def test_numbers_name_the_option_and_its_range(self):
        sweep = mjstepper.sweep
        self.assertRejects(ValueError, ["settle", "-1", "[0, 60] s"], sweep, RIGID, "40rpm",
                           settle=-1)
        self.assertRejects(ValueError, ["measure", "61"], sweep, RIGID, "40rpm", measure=61)
        self.assertRejects(ValueError, ["measure", "nan"], sweep, RIGID, "40rpm",
                           measure=math.nan)
        self.assertRejects(TypeError, ["measure = '0.5'"], sweep, RIGID, "40rpm", measure="0.5")
        self.assertRejects(TypeError, ["speeds = True"], sweep, RIGID, [True])
        self.assertRejects(ValueError, ["speeds: no speed"], sweep, RIGID, [])
        self.assertRejects(ValueError, ["speeds", "20000"], sweep, RIGID, [5.0, 2e4])
        self.assertRejects(ValueError, ["speeds", "inf"], sweep, RIGID, [math.inf])
        self.assertRejects(ValueError, ["vary", "-100"], mjstepper.map, COUPLING, "40rpm",
                           ("stiffness:coupling", [-100]))
        self.assertRejects(ValueError, ["vary", "damping:coupling"], mjstepper.map, COUPLING,
                           "40rpm", ("damping:coupling", [1]))
        self.assertRejects(ValueError, ["duration: 1000000000.0 is not in [1e-06, 1e+06] s"],
                           mjstepper.run, RIGID, 1e9)
        self.assertRejects(ValueError, ["mass", "payload=-2"], mjstepper.run, RIGID, 0.1,
                           mass={"payload": -2})
        self.assertRejects(ValueError, ["/no/such/model.xml"], sweep, "/no/such/model.xml",
                           "40rpm")
        self.assertRejects(ValueError, ["'nothing'", "not a stepper"], sweep, RIGID, "40rpm",
                           actuator="nothing")

    def test_messages_name_python_keywords_not_command_flags(self):
        # Issue 32, item 1: a Python user was told to "pass --allow-coarse", a flag of the command.
        arm6 = os.path.join(SOURCE, "models", "arm6.xml")
        with self.assertRaises(ValueError) as ctx:
            mjstepper.size(arm6, {"j2": "30,0deg"}, cycles=1)
        self.assertIn("pass allow_coarse=True", str(ctx.exception))
        self.assertNotIn("--", str(ctx.exception))
        self.assertRejects(ValueError, ["log_every", "[1, 1e+09]"], mjstepper.run, RIGID, 0.1,
                           log_every=0)

    def test_sweep_pullout_and_map_apply_the_timestep_rule(self):
        # Issue 32, item 5: a step too coarse for the stepper's mode is refused by every experiment
        # (it ran silently in sweep, map and pullout), and allow_coarse=True runs it anyway.
        path = rigid_at_timestep("1e-3", "tsui_1ms.xml")
        for function, args in ((mjstepper.sweep, (path, "40rpm")),
                               (mjstepper.pullout, (path, "100rpm")),
                               (mjstepper.map, (path, "40rpm", ("mass:rotor", [0.5])))):
            self.assertRejects(ValueError, ["too coarse", "allow_coarse=True"], function, *args)
        self.assertEqual(len(mjstepper.sweep(path, "40rpm", measure=0.2, allow_coarse=True)), 1)

    def test_python_keywords_are_the_commands_options(self):
        # Issue 32, item 1: every option has the same name in the command and in Python (the
        # command's parser lists them: mjstepper._engine.options), and each experiment's keywords
        # are exactly its subcommand's options, plus what only Python has (a run's traces).
        import inspect
        from mjstepper import _engine
        functions = {"run": (mjstepper.run, {"traces"}),
                     "sweep": (mjstepper._experiments.sweep_args, set()),
                     "map": (mjstepper._experiments.map_args, set()),
                     "pullout": (mjstepper._experiments.pullout_args, set()),
                     "identify": (mjstepper._experiments.identify_args, set()),
                     "resonance-test": (mjstepper._experiments.resonance_test_args, set()),
                     "size": (mjstepper.size, set()),
                     "attach": (mjstepper.attach, set())}
        for command, (function, python_only) in functions.items():
            options = {python for c, _, python, _ in _engine.options() if c == command}
            keywords = set(inspect.signature(function).parameters) - python_only
            self.assertEqual(keywords, options, command)
        mjstepper.run(RIGID, 0.01, quiet=True)  # issue 32: quiet=True was a TypeError

    def test_measure_holds_at_least_100_timesteps(self):
        path = rigid_at_timestep("2e-4", "tsui_coarse.xml")
        self.assertRejects(ValueError, ["measure 0.01", "at least 100 timesteps"],
                           mjstepper.sweep, path, "40rpm", measure=0.01)

    def test_out_replaces_only_a_regular_file(self):
        # A symbolic link, a FIFO or a directory as `out` is refused before any run, and left as
        # it was.
        folder = tempfile.mkdtemp()
        target = os.path.join(folder, "target.csv")
        with open(target, "w") as f:
            f.write("precious\n")
        link, fifo = os.path.join(folder, "link"), os.path.join(folder, "fifo")
        os.symlink(target, link + ".csv")
        os.mkfifo(fifo + ".csv")
        for out in (link, fifo):
            self.assertRejects(RuntimeError, [out + ".csv", "written only as regular files"],
                               mjstepper.sweep, RIGID, "40rpm", out=out)
        self.assertTrue(os.path.islink(link + ".csv"))
        self.assertTrue(stat.S_ISFIFO(os.lstat(fifo + ".csv").st_mode))
        with open(target) as f:
            self.assertEqual(f.read(), "precious\n")
        self.assertEqual(sorted(os.listdir(folder)), ["fifo.csv", "link.csv", "target.csv"])

    def test_without_ray_says_how_to_install_it(self):
        for function, args in ((mjstepper.distributed.sweep, (RIGID, "40rpm")),
                               (mjstepper.distributed.map,
                                (COUPLING, "40rpm", ("mass:load", [0.5])))):
            self.assertRejects(ModuleNotFoundError, ['pip install "ray==2.60.0"',
                                                     'mjstepper[ray]'], function, *args,
                               measure=0.2)


class HostileArguments(unittest.TestCase):
    """Issue 16: every argument of the package's functions is checked where it is given, and the
    error names it (and its range), instead of failing later or elsewhere."""

    def compiled(self, plain=False):
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        mjstepper.add_signal_sensors(spec)
        if plain:  # a second actuator, not a stepper
            spec.add_actuator(name="plain", target="shaft", trntype=mujoco.mjtTrn.mjTRN_JOINT)
        model = spec.compile()
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        return model, data

    def test_ctrl_c_interrupts_an_engine_call_within_half_a_second(self):
        # Issue 33: a 200 s run went on 13.5 s after SIGINT. Each call in a Python of its own,
        # SIGINT sent to it 2 s in: a KeyboardInterrupt, within 0.5 s, and no output left behind.
        script = """
import os, signal, sys, threading, time, mjstepper
sent = None
def interrupt():
    global sent
    time.sleep(2.0)
    sent = time.monotonic()
    os.kill(os.getpid(), signal.SIGINT)
threading.Thread(target=interrupt, daemon=True).start()
try:
    {call}
    print("finished")
except KeyboardInterrupt:
    print("interrupted after", time.monotonic() - sent)
"""
        out = os.path.join(os.getcwd(), "interrupted")
        for call in (f"mjstepper.run({RIGID!r}, 200, log={out + '.csv'!r})",
                     f"mjstepper.sweep({RIGID!r}, '10:2000:1rpm', threads=2)",
                     f"mjstepper.pullout({RIGID!r}, '10:2000:10rpm', threads=2)"):
            result = subprocess.run([sys.executable, "-c", script.format(call=call)],
                                    capture_output=True, text=True, timeout=120)
            words = result.stdout.split()
            self.assertEqual(words[:2], ["interrupted", "after"], call + result.stderr)
            self.assertLess(float(words[2]), 0.5, call)
        self.assertFalse(os.path.exists(out + ".csv"))
        self.assertFalse(os.path.exists(out + ".csv.tmp"))

    def test_signals_takes_any_integer_id_but_a_bool(self):
        model, data = self.compiled()
        by_name = mjstepper.signals(model, data, "shaft")
        for actuator in (0, np.int64(0), np.int32(0), np.uint8(0)):
            self.assertEqual(mjstepper.signals(model, data, actuator), by_name, repr(actuator))
        for actuator in (True, np.bool_(False), 0.0, None, b"shaft"):
            with self.assertRaises(TypeError) as ctx:
                mjstepper.signals(model, data, actuator)
            self.assertIn("actuator", str(ctx.exception))

    def test_signals_names_an_id_out_of_range_and_a_non_stepper(self):
        model, data = self.compiled(plain=True)
        for actuator in (99, np.int64(2), -1):
            with self.assertRaises(IndexError) as ctx:
                mjstepper.signals(model, data, actuator)
            message = str(ctx.exception)
            self.assertIn(f"no actuator {int(actuator)}", message)
            self.assertIn("[0, model.nactuator) = [0, 2)", message)
            self.assertNotIn("sensor", message)
        for actuator in ("plain", 1):
            with self.assertRaises(ValueError) as ctx:
                mjstepper.signals(model, data, actuator)
            self.assertIn("'plain' (id 1) is not an mjstepper stepper", str(ctx.exception))
        self.assertEqual(tuple(mjstepper.signals(model, data, 0)), mjstepper.SIGNALS)

    def test_configure_rejects_an_unknown_attribute_at_once(self):
        spec = mujoco.MjSpec.from_file(os.path.join(SOURCE, "models", "tsui_rigid.xml"))
        before = dict(spec.actuators[0].plugin.config)
        with self.assertRaises(ValueError) as ctx:
            mjstepper.configure(spec, "shaft", hold_current=1.5, hold_curent=1)
        self.assertIn("'hold_curent'", str(ctx.exception))
        self.assertIn("did you mean hold_current", str(ctx.exception))
        self.assertEqual(dict(spec.actuators[0].plugin.config), before)  # nothing set
        for attribute, value in (("hold_current", None), ("hold_current", True),
                                 ("microsteps", 2.5), ("detent", [])):
            with self.assertRaises(TypeError) as ctx:
                mjstepper.configure(spec, "shaft", **{attribute: value})
            self.assertIn(f"{attribute} = {value!r}", str(ctx.exception))
        self.assertEqual(dict(spec.actuators[0].plugin.config), before)
        mjstepper.configure(spec, "shaft", hold_current=np.float64(1.5), microsteps=np.int64(16),
                            gauge=False, detent="none")
        self.assertEqual({k: v for k, v in spec.actuators[0].plugin.config.items()
                          if k not in before},
                         {"hold_current": "1.5", "microsteps": "16", "gauge": "off",
                          "detent": "none"})
        spec.compile()

    def test_attribute_names_are_the_plugins_table(self):
        """mjstepper.ATTRIBUTES (generated from the C++ table) lists plugin/README.md's table,
        which is generated from the same table (and checked by a C++ test)."""
        with open(os.path.join(SOURCE, "plugin", "README.md"), encoding="utf-8") as f:
            lines = f.read().split("| Attribute | Type |", 1)[1].splitlines()[2:]
        documented = []
        for line in lines:
            if not line.startswith("| `"):
                break
            documented.append(line.split("`")[1])
        self.assertEqual(mjstepper.ATTRIBUTES, tuple(documented))
        self.assertEqual(mjstepper.ATTRIBUTE_UNITS["hold_current"], "A")


class DocsPython(unittest.TestCase):
    """Issue 32, items 1 and 6: every Python block of the README and docs/ runs as written, with
    the installed package, in an empty scratch folder: its `models/…` paths are the package's own
    example models (installation.h, FindModel)."""

    def test_the_example_models_come_with_the_package(self):
        folder = tempfile.mkdtemp(prefix="mjstepper_models_")
        listed = subprocess.run([MJSTEPPER, "models"], cwd=folder, capture_output=True, text=True)
        self.assertEqual(listed.returncode, 0, listed.stderr)
        self.assertIn("  tsui_rigid\n", listed.stdout)
        self.assertIn(os.path.dirname(mjstepper.__file__), listed.stdout)
        info = subprocess.run([MJSTEPPER, "info", "models/tsui_rigid.xml"], cwd=folder,
                              capture_output=True, text=True)
        self.assertEqual(info.returncode, 0, info.stderr)
        self.assertEqual(mjstepper.run("tsui_rigid", 0.01).steps, 200)

    def test_every_python_block_runs(self):
        import glob
        import re
        fence = re.compile(r"^```python[^\n]*\n(.*?)^```", re.S | re.M)
        docs = ["README.md"] + sorted(glob.glob("docs/**/*.md", root_dir=SOURCE, recursive=True))
        folder = tempfile.mkdtemp(prefix="mjstepper_docs_python_")
        ran = 0
        for doc in docs:
            with open(os.path.join(SOURCE, doc), encoding="utf-8") as f:
                text = f.read()
            for m in fence.finditer(text):
                line = text.count("\n", 0, m.start()) + 1
                with self.subTest(block=f"{doc}:{line}"):
                    proc = subprocess.run([sys.executable, "-c", m.group(1)], cwd=folder,
                                          capture_output=True, text=True, timeout=600)
                    self.assertEqual(proc.returncode, 0, f"{doc}:{line}\n{proc.stderr[-3000:]}")
                ran += 1
        self.assertGreaterEqual(ran, 4)  # README's three (one with Ray), docs/ray.md's


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1] + sys.argv[3:], verbosity=2)  # optionally test classes
