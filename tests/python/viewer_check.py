"""mujoco.viewer.launch_passive with the plugin, on a virtual X screen (ctest runs this under
xvfb-run): the viewer runs the model, and a frame grabbed from the screen shows the drive's gauge,
whose rotor arrow is the only magenta in the scene; with gauge="off" there is none.
    viewer_check.py PLUGIN SOURCE_DIR"""
import sys
import threading
import time
import unittest

import mujoco
import mujoco.viewer

from xscreen import count_pixels, grab_screen

PLUGIN, SOURCE = sys.argv[1], sys.argv[2]


def magenta_pixels(gauge):
    with open(f"{SOURCE}/models/tsui_rigid.xml") as f:
        xml = f.read().replace('<config key="input"',
                               f'<config key="gauge" value="{gauge}"/><config key="input"')
    model = mujoco.MjModel.from_xml_string(xml)
    data = mujoco.MjData(model)
    with mujoco.viewer.launch_passive(model, data) as viewer:
        viewer.cam.type = mujoco.mjtCamera.mjCAMERA_FIXED
        viewer.cam.fixedcamid = 0  # "front", looking down at the rotor
        for _ in range(400):  # 20 ms at 100 r/min
            data.ctrl[0] = 10.0
            mujoco.mj_step(model, data)
            viewer.sync()
            time.sleep(0.002)
        time.sleep(1.0)  # let the render thread draw the last state
        running = viewer.is_running()
        screen = grab_screen()
    # close() only asks the viewer's (daemon) thread to stop: wait until it has destroyed its
    # window, or it may still be doing so when glfw.terminate runs at exit (a segfault in GLFW).
    for thread in threading.enumerate():
        if thread is not threading.main_thread():
            thread.join(timeout=30)
    count = count_pixels(screen, lambda r, g, b: r > 120 and b > 120 and g < 0.5 * min(r, b))
    return running, count, data.qpos[0]


class PassiveViewer(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        mujoco.mj_loadPluginLibrary(PLUGIN)

    def test_viewer_runs_and_shows_the_gauge(self):
        running, with_gauge, turned = magenta_pixels("on")
        self.assertTrue(running)
        self.assertGreater(turned, 0.1)  # the viewer's model moved: 10 rad/s for 20 ms
        _, without_gauge, _ = magenta_pixels("off")
        self.assertGreater(with_gauge, 30)  # the rotor arrow: about 90 sampled pixels
        self.assertLess(without_gauge, 5)


if __name__ == "__main__":
    unittest.main(argv=sys.argv[:1], verbosity=2)
