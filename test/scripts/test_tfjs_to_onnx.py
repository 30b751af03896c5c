#!/usr/bin/env python3
"""Tests of scripts/tfjs_to_onnx.py (TF.js graph model -> ONNX for OpenCV's DNN) on small
YOLOv5-like TF.js graphs written by tfjs_test_graph.py, run with OpenCV's DNN (python3-opencv):

* at the graph's own 64 x 64 input, the ONNX output equals the numpy reference run of the TF
  graph (boxes scaled from fractions to pixels; left as they are with --source-boxes pixels);
* at other sizes (64 x 32, 32 x 64, 96 x 64) the rebuilt head equals YOLOv5's box decoding of the
  reference backbone's raw head outputs at that size, cell by cell;
* on the block-local graph, the same content gives the same boxes at 64 x 64 and 64 x 32 in the
  area both inputs cover;
* one-line errors for a missing or corrupt model.json or shard, an unsupported op, a bad --input.

usage: test_tfjs_to_onnx.py [--junit FILE]
"""
import json
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import junit_runner  # noqa: E402
import tfjs_test_graph as graph  # noqa: E402

CONVERTER = os.path.join(ROOT, "scripts", "tfjs_to_onnx.py")
PYTHON = "/usr/bin/python3"

try:
    import cv2
except ImportError:  # the test fails below with a clear message
    cv2 = None


def run_converter(*args):
    return subprocess.run([PYTHON, CONVERTER] + [str(a) for a in args], capture_output=True, text=True)


class ConverterTest(unittest.TestCase):
    """Converts the test graphs once per size and runs them with OpenCV."""

    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory()
        cls.models = {kind: graph.write_model(os.path.join(cls.dir.name, kind), kind) for kind in ("full", "local")}
        cls.onnx = {}

    @classmethod
    def tearDownClass(cls):
        cls.dir.cleanup()

    def setUp(self):
        self.assertIsNotNone(cv2, "python3-opencv is not installed (scripts/install_deps.sh installs it)")

    def convert(self, kind, width, height):
        key = (kind, width, height)
        if key not in self.onnx:
            path = os.path.join(self.dir.name, "%s-%dx%d.onnx" % key)
            done = run_converter(self.models[kind][0], path, "--input", "%dx%d" % (width, height))
            self.assertEqual(done.returncode, 0, done.stderr)
            self.assertIn("output [1, %d, %d]" % (self.rows(width, height), graph.COLUMNS), done.stdout)
            self.onnx[key] = path
        return self.onnx[key]

    @staticmethod
    def rows(width, height):
        return 3 * sum((width // s) * (height // s) for s in (8, 16, 32))

    def forward(self, path, image):
        """OpenCV's output for an NHWC RGB image in [0, 1], fed as YoloDetector feeds (NCHW)."""
        net = cv2.dnn.readNetFromONNX(path)
        net.setInput(np.ascontiguousarray(image.transpose(0, 3, 1, 2), np.float32))
        out = net.forward()
        self.assertEqual(out.shape, (1, self.rows(image.shape[2], image.shape[1]), graph.COLUMNS))
        return out[0].astype(np.float64)

    def test_matches_the_tf_graph_at_its_own_size(self):
        image = np.random.default_rng(0).random((1, 64, 64, 3))
        for kind in ("full", "local"):
            with self.subTest(kind=kind):
                reference = graph.Reference(self.models[kind][0]).run(image)["Identity"][0]
                reference[:, :4] *= 64  # the graph gives fractions of its 64 x 64 input
                out = self.forward(self.convert(kind, 64, 64), image)
                np.testing.assert_allclose(out, reference, rtol=1e-5, atol=1e-4)
                # The objectness and class columns are probabilities, not saturated.
                self.assertGreater(np.std(out[:, 4:]), 0.05)

    def test_rebuilt_head_decodes_every_cell_at_other_sizes(self):
        rng = np.random.default_rng(1)
        model, heads = self.models["full"]
        reference = graph.Reference(model)
        for width, height in ((64, 32), (32, 64), (96, 64)):
            with self.subTest(size="%dx%d" % (width, height)):
                image = rng.random((1, height, width, 3))
                raw = reference.run(image, [name for name, _ in heads], keep_resize_factor=True)
                expected = np.concatenate([graph.decode_head(raw[name], stride) for name, stride in heads])
                out = self.forward(self.convert("full", width, height), image)
                np.testing.assert_allclose(out, expected, rtol=1e-5, atol=1e-4)

    def test_same_content_gives_the_same_boxes_at_64x64_and_64x32(self):
        # The block-local graph: a cell sees only its own stride x stride block, so the top half
        # of a 64 x 64 image, alone in a 64 x 32 input, must give the same cells there, with the
        # same boxes in pixels.
        image = np.random.default_rng(2).random((1, 64, 64, 3))
        square = self.forward(self.convert("local", 64, 64), image)
        wide = self.forward(self.convert("local", 64, 32), image[:, :32])
        compared, offset_square, offset_wide = 0, 0, 0
        for stride in (8, 16, 32):
            nx, ny_square, ny_wide = 64 // stride, 64 // stride, 32 // stride
            for anchor in range(3):
                for y in range(ny_wide):
                    for x in range(nx):
                        a = square[offset_square + anchor * ny_square * nx + y * nx + x]
                        b = wide[offset_wide + anchor * ny_wide * nx + y * nx + x]
                        np.testing.assert_allclose(b, a, rtol=1e-5, atol=1e-4,
                                                   err_msg="stride %d anchor %d cell (%d, %d)" % (stride, anchor, x, y))
                        compared += 1
            offset_square += 3 * ny_square * nx
            offset_wide += 3 * ny_wide * nx
        self.assertEqual(compared, 3 * (8 * 4 + 4 * 2 + 2 * 1))
        # The boxes really are in pixels and spread over the grid (not fractions).
        self.assertGreater(wide[:, 0].max(), 40.0)

    def test_source_boxes_pixels_leaves_the_box_scales(self):
        # A model whose boxes are already in pixels (here: read so) keeps its scale constants.
        image = np.random.default_rng(3).random((1, 64, 64, 3))
        path = os.path.join(self.dir.name, "pixels.onnx")
        done = run_converter(self.models["local"][0], path, "--source-boxes", "pixels")
        self.assertEqual(done.returncode, 0, done.stderr)
        reference = graph.Reference(self.models["local"][0]).run(image)["Identity"][0]
        np.testing.assert_allclose(self.forward(path, image), reference, rtol=1e-5, atol=1e-5)

    def test_onnx_model_interface(self):
        import onnx
        model = onnx.load(self.convert("full", 96, 64))
        self.assertEqual(model.opset_import[0].version, 12)
        (graph_input,), (graph_output,) = model.graph.input, model.graph.output
        self.assertEqual(graph_input.name, "images")
        self.assertEqual([d.dim_value for d in graph_input.type.tensor_type.shape.dim], [1, 3, 64, 96])
        self.assertEqual(graph_output.name, "output")
        self.assertEqual([d.dim_value for d in graph_output.type.tensor_type.shape.dim],
                         [1, self.rows(96, 64), graph.COLUMNS])
        ops = {node.op_type for node in model.graph.node}
        self.assertTrue({"Conv", "MaxPool", "Resize", "Pad", "Slice", "Reshape", "Transpose", "Concat"} <= ops, ops)
        # Every Pad in front of a convolution went into the convolution's pads: one Pad is left
        # (the one feeding a max pool).
        self.assertEqual(sum(node.op_type == "Pad" for node in model.graph.node), 1)

    def test_verify_option_runs_opencv(self):
        out = os.path.join(self.dir.name, "verified.onnx")
        done = run_converter(self.models["local"][0], out, "--input", "64x32", "--verify")
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("OpenCV", done.stdout)


class ErrorTest(unittest.TestCase):
    """One line on stderr and exit status 1 for every bad input."""

    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.tmp = self.dir.name
        self.model, _ = graph.write_model(os.path.join(self.tmp, "model"), "local")
        self.out = os.path.join(self.tmp, "out.onnx")

    def tearDown(self):
        self.dir.cleanup()

    def assert_error(self, args, *fragments):
        done = run_converter(*args)
        self.assertEqual(done.returncode, 1, done.stdout + done.stderr)
        lines = done.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, done.stderr)
        self.assertTrue(lines[0].startswith("tfjs_to_onnx: "), lines[0])
        for fragment in fragments:
            self.assertIn(fragment, lines[0])
        self.assertFalse(os.path.exists(self.out))

    def edit_model(self, change):
        with open(self.model) as f:
            model = json.load(f)
        change(model)
        with open(self.model, "w") as f:
            json.dump(model, f)

    def test_missing_model_json(self):
        missing = os.path.join(self.tmp, "nothing", "model.json")
        self.assert_error([missing, self.out], "cannot read", missing)

    def test_corrupt_model_json(self):
        with open(self.model, "w") as f:
            f.write('{"modelTopology": {"node": [')
        self.assert_error([self.model, self.out], "not valid JSON", "line 1")

    def test_not_a_graph_model(self):
        with open(self.model, "w") as f:
            json.dump({"modelTopology": {"class_name": "Sequential"}, "format": "layers-model"}, f)
        self.assert_error([self.model, self.out], "not a TF.js graph model")

    def test_missing_shard(self):
        shard = os.path.join(os.path.dirname(self.model), "group1-shard2of2.bin")
        os.remove(shard)
        self.assert_error([self.model, self.out], "weight shard", shard)

    def test_truncated_shard(self):
        shard = os.path.join(os.path.dirname(self.model), "group1-shard1of2.bin")
        with open(shard, "r+b") as f:
            f.truncate(100)
        self.assert_error([self.model, self.out], "truncated", "describes")

    def test_unsupported_op(self):
        def relu6(model):
            for node in model["modelTopology"]["node"]:
                if node["op"] == "Sigmoid":
                    node["op"] = "Relu6"
                    break
        self.edit_model(relu6)
        self.assert_error([self.model, self.out], "op Relu6 is not supported")

    def test_bad_input_sizes(self):
        for size in ("100x64", "64x0", "-32x64", "64", "64x64x3", "abc"):
            with self.subTest(size=size):
                self.assert_error([self.model, self.out, "--input=" + size], "--input")

    def test_help(self):
        done = run_converter("--help")
        self.assertEqual(done.returncode, 0)
        self.assertIn("--input", done.stdout)
        self.assertIn("--source-boxes", done.stdout)


if __name__ == "__main__":
    sys.exit(junit_runner.main(__name__, __doc__.splitlines()[0]))
