#!/usr/bin/env python3
"""Failures a user meets at the launch, seen as the user sees them: a nodelet that cannot start
(here the detector, whose model file is missing) ends perception.launch within seconds, naming
the file, instead of leaving a manager that runs without it; and `rostopic echo /diagnostics`
can load its message class (python3-diagnostic-msgs, scripts/install_deps.sh). Needs the devel
space sourced (scripts/run_tests.sh does); roslaunch starts its own master on a free port.

usage: test_launch_failures.py [--junit FILE]
"""
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import junit_runner  # noqa: E402


LAUNCH = """<launch>
  <env name="LD_PRELOAD" value="$(optenv GVF_TEST_PRELOAD)"/>
  <include file="$(find grid_vision_fusion)/launch/perception.launch">
    <arg name="model" value="%s"/>
  </include>
</launch>
"""


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class LaunchFailureTest(unittest.TestCase):
    def test_a_nodelet_that_cannot_start_ends_the_launch(self):
        if shutil.which("roslaunch") is None:
            self.fail("roslaunch is not on PATH: source the devel space's setup.bash")
        model = "/nonexistent/models/yolov5s-640x192.onnx"
        with tempfile.TemporaryDirectory() as work:
            # perception.launch as a user starts it; the sanitizer build's runtime (GVF_TEST_PRELOAD,
            # scripts/run_tests.sh --sanitize) goes into the nodes only, as in the rostests.
            launch = os.path.join(work, "perception_without_model.launch")
            with open(launch, "w") as f:
                f.write(LAUNCH % model)
            try:
                done = subprocess.run(
                    ["roslaunch", "-p", str(free_port()), launch], stdout=subprocess.PIPE,
                    stderr=subprocess.STDOUT, text=True, timeout=90, env=dict(os.environ, ROS_LOG_DIR=work))
            except subprocess.TimeoutExpired as e:
                self.fail("the launch still ran after 90 s with a missing model:\n%s" % (e.stdout or ""))
        for text in (model + ": cannot open the ONNX model file", "yolo_detector: cannot start"):
            self.assertIn(text, done.stdout, done.stdout[-4000:])
        self.assertRegex(done.stdout, r"REQUIRED process \[yolo_detector-\d+\] has died", done.stdout[-4000:])

    def test_the_diagnostics_message_class_loads(self):
        import roslib.message
        self.assertIsNotNone(roslib.message.get_message_class("diagnostic_msgs/DiagnosticArray"),
                             "rostopic echo /diagnostics cannot load diagnostic_msgs/DiagnosticArray: "
                             "install python3-diagnostic-msgs")


if __name__ == "__main__":
    sys.exit(junit_runner.main(__name__, __doc__.splitlines()[0]))
