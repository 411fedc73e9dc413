"""The plugin from Python: mujoco.mj_loadPluginLibrary, load MJCF, step, read signals."""
import math
import os
import sys
import unittest

import mujoco
import numpy as np

PLUGIN = os.environ["MJSTEPPER_PLUGIN"]
SOURCE = os.environ["MJSTEPPER_SOURCE_DIR"]
sys.path.insert(0, os.path.join(SOURCE, "src", "tools", "python"))
from mjstepper_signals import signal_table  # noqa: E402  the one signal table


class PluginFromPython(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        mujoco.mj_loadPluginLibrary(PLUGIN)

    def test_loads_steps_and_reads_signals(self):
        with open(os.path.join(SOURCE, "models", "tsui_rigid.xml")) as f:
            xml = f.read()
        probe = ('<sensor><plugin name="shaft_signals" plugin="mjstepper.stepper" '
                 'objtype="actuator" objname="shaft"/></sensor></mujoco>')
        model = mujoco.MjModel.from_xml_string(xml.replace("</mujoco>", probe))
        data = mujoco.MjData(model)
        omega = 100 * 2 * math.pi / 60  # rad/s
        for _ in range(4000):  # 0.2 s at 100 r/min (velocity input)
            data.ctrl[0] = omega
            mujoco.mj_step(model, data)
        signals = data.sensor("shaft_signals").data
        names = [row[0] for row in signal_table()]
        self.assertEqual(len(signals), len(names))
        # The rotor turned about ω·t (a synchronous motor; ±2 % for the start transient).
        self.assertAlmostEqual(data.qpos[0] / (omega * 0.2), 1.0, delta=0.02)
        # Current amplitude held near 1.9 A by the PI loop (±10 %: ripple and loop lag).
        self.assertAlmostEqual(math.hypot(signals[names.index("current_a")],
                                          signals[names.index("current_b")]), 1.9, delta=0.19)
        self.assertEqual(signals[names.index("lost_steps")], 0.0)

    def test_rollout_threads_match_serial(self):
        """mujoco.rollout over 8 runs (8 speeds) on 2 threads is bit-identical to 1 thread: all
        drive state lives in plugin_state, and each thread's mjData carries its own."""
        from mujoco import rollout
        with open(os.path.join(SOURCE, "models", "tsui_rigid.xml")) as f:
            xml = f.read()
        probe = ('<sensor><plugin name="shaft_signals" plugin="mjstepper.stepper" '
                 'objtype="actuator" objname="shaft"/></sensor></mujoco>')
        model = mujoco.MjModel.from_xml_string(xml.replace("</mujoco>", probe))
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        data = mujoco.MjData(model)
        state = np.zeros(mujoco.mj_stateSize(model, spec))
        mujoco.mj_getState(model, data, state, spec)
        speeds = np.linspace(10, 200, 8) * 2 * math.pi / 60  # rad/s, through the resonances
        control = np.repeat(speeds[:, None, None], 2000, axis=1)  # 8 runs × 2000 steps × 1
        initial = np.repeat(state[None, :], len(speeds), axis=0)
        results = []
        for threads in (1, 2):
            datas = [mujoco.MjData(model) for _ in range(threads)]
            results.append(rollout.rollout(model, datas, initial, control))
        serial, parallel = results
        self.assertTrue(np.array_equal(serial[0], parallel[0]))  # states, plugin state included
        self.assertTrue(np.array_equal(serial[1], parallel[1]))  # sensordata: the signals
        # The runs differ (not 8 copies of one), and the rotors turned.
        self.assertFalse(np.array_equal(serial[1][0], serial[1][-1]))
        self.assertGreater(abs(serial[0][-1, -1, 1]), 0.1)

    def test_bad_config_names_attribute(self):
        with open(os.path.join(SOURCE, "models", "tsui_rigid.xml")) as f:
            xml = f.read().replace('<config key="input"',
                                   '<config key="hold_current" value="-1.9"/><config key="input"')
        with self.assertRaises(ValueError) as ctx:
            mujoco.MjModel.from_xml_string(xml)
        self.assertIn('hold_current = "-1.9"', str(ctx.exception))

    def test_load_errors_in_model_order(self):
        """Issue 16: with two bad steppers Python showed only the second one's error. Now both,
        the first actuator's first (MuJoCo 4.0's compiler repeats them after: see
        plugin/README.md)."""
        with open(os.path.join(SOURCE, "models", "tsui_rigid.xml")) as f:
            xml = f.read()
        start = xml.index("<plugin name=\"shaft\"")
        end = xml.index("</plugin>", start) + len("</plugin>")
        first = xml[start:end].replace('<config key="input"',
                                       '<config key="bus_voltage" value="48V"/><config key="input"')
        second = xml[start:end].replace('name="shaft"', 'name="shaft2"').replace(
            '<config key="input"', '<config key="kp" value="x"/><config key="input"')
        with self.assertRaises(ValueError) as ctx:
            mujoco.MjModel.from_xml_string(xml[:start] + first + second + xml[end:])
        message = str(ctx.exception)
        first_error = message.find("actuator 'shaft' (id 0): bus_voltage = \"48V\"")
        second_error = message.find("actuator 'shaft2' (id 1): kp = \"x\"")
        self.assertGreaterEqual(first_error, 0, message)
        self.assertGreater(second_error, first_error, message)


if __name__ == "__main__":
    unittest.main()
