"""Small YOLOv5-like TensorFlow.js graph models written by the tests, and an independent numpy
interpreter of the TF ops they use (NHWC, TF's own semantics), for test_tfjs_to_onnx.py and
test_fetch_model.py.

write_model(directory, kind) writes model.json and two weight shards (split in the middle of a
tensor, as the TF.js converter does) of one of two graphs made for a 64 x 64 input:

* "full": every op that scripts/tfjs_to_onnx.py maps: a 6 x 6 stride-2 stem behind an explicit
  Pad, 3 x 3 stride-2 convolutions behind Pads, a residual bottleneck (AddV2), SPPF (three 5 x 5
  SAME max pools and a four-way ConcatV2), a Pad feeding a VALID max pool (a Pad that is not
  folded into a convolution), two nearest-neighbour upsamplings with concatenations, and a
  YOLOv5 TF-export head on strides 8, 16, 32 (Reshape, Transpose, Sigmoid, StridedSlice with
  ellipsis and end masks, Mul, Add of the baked grid, Square, Mul by the baked anchor grid,
  ConcatV2, Reshape, ConcatV2, Identity), boxes as fractions of 64 x 64;
* "local": the same head on three block convolutions (kernel = stride = 8, 16, 32, VALID), so
  that every output cell depends on its own block of pixels only: the same content gives the
  same cells at any input size.
"""
import base64
import json
import os

import numpy as np

NUM_CLASSES = 2
ANCHORS = {8: [(10, 13), (16, 30), (33, 23)], 16: [(30, 61), (62, 45), (59, 119)],
           32: [(116, 90), (156, 198), (373, 326)]}
SIZE = 64
COLUMNS = 5 + NUM_CLASSES


class DType(str):
    """A TF dtype attribute value such as DT_FLOAT."""


def encode_attr(value):
    if isinstance(value, DType):
        return {"type": str(value)}
    if isinstance(value, bool):
        return {"b": value}
    if isinstance(value, int):
        return {"i": str(value)}
    if isinstance(value, float):
        return {"f": value}
    if isinstance(value, str):
        return {"s": base64.b64encode(value.encode()).decode()}
    if isinstance(value, list) and all(isinstance(v, str) for v in value) and value:
        return {"list": {"s": [base64.b64encode(v.encode()).decode() for v in value]}}
    if isinstance(value, list):
        return {"list": {"i": [str(v) for v in value]}}
    raise TypeError(value)


class GraphBuilder:
    """Collects TF nodes and constants and writes them as a TF.js graph model."""

    def __init__(self, seed):
        self.nodes = []
        self.constants = []
        self.rng = np.random.default_rng(seed)
        self.count = 0

    def name(self, prefix):
        self.count += 1
        return "model/%s_%d" % (prefix, self.count)

    def const(self, prefix, value):
        name = self.name(prefix)
        dtype = "DT_INT32" if value.dtype == np.int32 else "DT_FLOAT"
        self.nodes.append({"name": name, "op": "Const", "attr": {"dtype": encode_attr(DType(dtype)), "value": {
            "tensor": {"dtype": dtype, "tensorShape": {"dim": [{"size": str(d)} for d in value.shape]}}}}})
        self.constants.append((name, value))
        return name

    def op(self, op, prefix, inputs, **attrs):
        name = self.name(prefix)
        attr = {"T": encode_attr(DType("DT_FLOAT"))}
        attr.update({key: encode_attr(value) for key, value in attrs.items()})
        self.nodes.append({"name": name, "op": op, "input": list(inputs), "attr": attr})
        return name

    def conv(self, x, cin, cout, kernel, stride=1, padding="SAME", silu=True, bias=0.0):
        scale = np.sqrt(2.0 / (kernel * kernel * cin))
        w = self.const("kernel", (self.rng.standard_normal((kernel, kernel, cin, cout)) * scale).astype(np.float32))
        b = self.const("bias", (self.rng.standard_normal(cout) * 0.2 + bias).astype(np.float32))
        y = self.op("_FusedConv2D", "conv", [x, w, b], strides=[1, stride, stride, 1], padding=padding,
                    dilations=[1, 1, 1, 1], data_format="NHWC", fused_ops=["BiasAdd"], num_args=1,
                    explicit_paddings=[], epsilon=0.0, use_cudnn_on_gpu=True)
        if not silu:
            return y
        return self.op("Mul", "silu", [y, self.op("Sigmoid", "sigmoid", [y])])

    def pad(self, x, amount):
        paddings = np.array([[0, 0], [amount, amount], [amount, amount], [0, 0]], np.int32)
        return self.op("Pad", "pad", [x, self.const("paddings", paddings)], Tpaddings=DType("DT_INT32"))

    def maxpool(self, x, size, padding):
        return self.op("MaxPool", "maxpool", [x], ksize=[1, size, size, 1], strides=[1, 1, 1, 1], padding=padding,
                       data_format="NHWC", explicit_paddings=[])

    def concat(self, inputs, axis):
        return self.op("ConcatV2", "concat", list(inputs) + [self.const("axis", np.array(axis, np.int32))],
                       N=len(inputs), Tidx=DType("DT_INT32"))

    def upsample(self, x, size):
        return self.op("ResizeNearestNeighbor", "upsample", [x, self.const("size", np.array(size, np.int32))],
                       align_corners=False, half_pixel_centers=True)

    def slice_last(self, x, begin, end):
        """x[..., begin:end] (end None: to the end), as the TF export writes it."""
        stack = [self.const("stack", np.array(v, np.int32)) for v in ([0, begin], [0, end or 0], [1, 1])]
        return self.op("StridedSlice", "strided_slice", [x] + stack, Index=DType("DT_INT32"), begin_mask=0,
                       end_mask=2 if end is None else 0, ellipsis_mask=1, new_axis_mask=0, shrink_axis_mask=0)

    def head_level(self, features, channels, stride):
        """One level of YOLOv5's TF-export head for a SIZE x SIZE input (boxes as fractions)."""
        ny = nx = SIZE // stride
        raw = self.conv(features, channels, 3 * COLUMNS, 1, silu=False)
        y = self.op("Reshape", "reshape", [raw, self.const("shape", np.array([-1, ny * nx, 3, COLUMNS], np.int32))],
                    Tshape=DType("DT_INT32"))
        y = self.op("Transpose", "transpose", [y, self.const("perm", np.array([0, 2, 1, 3], np.int32))],
                    Tperm=DType("DT_INT32"))
        y = self.op("Sigmoid", "sigmoid", [y])
        k = np.arange(ny * nx)
        grid = (np.stack([k % nx, k // nx], axis=1) - 0.5).reshape(1, 1, ny * nx, 2).astype(np.float32)
        two = self.const("two", np.array(2.0, np.float32))
        xy = self.op("Mul", "mul", [self.slice_last(y, 0, 2), two])
        xy = self.op("Add", "add", [xy, self.const("grid", grid)])
        xy = self.op("Mul", "truediv", [xy, self.const("stride", np.array([[stride / SIZE] * 2], np.float32))])
        wh = self.op("Square", "pow", [self.op("Mul", "mul", [self.slice_last(y, 2, 4), two])])
        anchors = (np.array(ANCHORS[stride], np.float32) / SIZE).reshape(1, 3, 1, 2)
        wh = self.op("Mul", "truediv", [wh, self.const("anchor_grid", anchors)])
        y = self.concat([xy, wh, self.slice_last(y, 4, None)], -1)
        return self.op("Reshape", "reshape", [y, self.const("shape", np.array([-1, 3 * ny * nx, COLUMNS], np.int32))],
                       Tshape=DType("DT_INT32")), raw

    def write(self, directory, output, shards=2):
        os.makedirs(directory, exist_ok=True)
        data = b"".join(np.ascontiguousarray(v).tobytes() for _, v in self.constants)
        cut = [len(data) * i // shards for i in range(shards + 1)]
        paths = ["group1-shard%dof%d.bin" % (i + 1, shards) for i in range(shards)]
        for i, path in enumerate(paths):
            with open(os.path.join(directory, path), "wb") as f:
                f.write(data[cut[i]:cut[i + 1]])
        manifest = [{"paths": paths, "weights": [
            {"name": n, "shape": list(v.shape), "dtype": "int32" if v.dtype == np.int32 else "float32"}
            for n, v in self.constants]}]
        placeholder = {"name": "input_1", "op": "Placeholder", "attr": {
            "dtype": encode_attr(DType("DT_FLOAT")),
            "shape": {"shape": {"dim": [{"size": str(d)} for d in (1, SIZE, SIZE, 3)]}}}}
        model = {"format": "graph-model", "generatedBy": "test", "convertedBy": "tfjs_test_graph.py",
                 "signature": {"outputs": {"tf_detect": {"name": "Identity:0"}}},
                 "modelTopology": {"node": self.constants_first() + [placeholder] + self.ops() + [
                     {"name": "Identity", "op": "Identity", "input": [output], "attr": {}}]},
                 "weightsManifest": manifest}
        path = os.path.join(directory, "model.json")
        with open(path, "w") as f:
            json.dump(model, f)
        return path

    def constants_first(self):
        return [n for n in self.nodes if n["op"] == "Const"]

    def ops(self):
        # Not in topological order (as in real exports): the converter must sort them.
        ops = [n for n in self.nodes if n["op"] != "Const"]
        return ops[1::2] + ops[0::2]


def write_model(directory, kind="full", seed=1):
    """Writes the "full" or "local" test graph; returns (model.json path, head conv node names
    with their strides)."""
    g = GraphBuilder(seed)
    x = "input_1"
    if kind == "full":
        c1 = g.conv(g.pad(x, 2), 3, 8, 6, 2, "VALID")  # 32 x 32
        c2 = g.conv(g.pad(c1, 1), 8, 16, 3, 2, "VALID")  # 16 x 16
        residual = g.op("AddV2", "add", [c2, g.conv(g.conv(c2, 16, 8, 1), 8, 16, 3)])
        p3 = g.conv(g.pad(residual, 1), 16, 16, 3, 2, "VALID")  # 8 x 8, stride 8
        p4 = g.conv(g.pad(p3, 1), 16, 16, 3, 2, "VALID")  # 4 x 4
        p5 = g.conv(g.pad(p4, 1), 16, 16, 3, 2, "VALID")  # 2 x 2
        # Linear and mostly negative before the max pools: padding with zeros instead of -inf (SAME
        # pools), or with -inf instead of zeros (the explicit Pad), would change the result.
        s = g.conv(p5, 16, 8, 1, silu=False, bias=-1.5)
        m1 = g.maxpool(s, 5, "SAME")
        m2 = g.maxpool(m1, 5, "SAME")
        m3 = g.maxpool(m2, 5, "SAME")
        sppf = g.conv(g.concat([s, m1, m2, m3], 3), 32, 16, 1, silu=False, bias=-1.5)
        n5 = g.maxpool(g.pad(sppf, 1), 3, "VALID")  # a Pad that no convolution takes over
        n4 = g.conv(g.concat([g.upsample(n5, [4, 4]), p4], 3), 32, 16, 1)
        n3 = g.conv(g.concat([g.upsample(n4, [8, 8]), p3], 3), 32, 16, 3)
        features = [(n3, 8), (n4, 16), (n5, 32)]
    elif kind == "local":
        features = [(g.conv(x, 3, 16, s, s, "VALID"), s) for s in (8, 16, 32)]
    else:
        raise ValueError(kind)
    levels = [g.head_level(f, 16, stride) for f, stride in features]
    output = g.concat([level for level, _ in levels], 1)
    path = g.write(directory, output)
    return path, [(raw, stride) for (_, raw), (_, stride) in zip(levels, features)]


# --- the numpy reference -------------------------------------------------------------------


def _attr(node, key, default=None):
    value = node.get("attr", {}).get(key)
    if value is None:
        return default
    if "list" in value:
        items = value["list"]
        if "s" in items:
            return [base64.b64decode(s).decode() for s in items["s"]]
        return [int(i) for i in items.get("i", [])]
    if "s" in value:
        return base64.b64decode(value["s"]).decode()
    if "b" in value:
        return value["b"]
    if "i" in value:
        return int(value["i"])
    return value


def _same(size, kernel, stride):
    out = -(-size // stride)
    total = max((out - 1) * stride + kernel - size, 0)
    return total // 2, total - total // 2


def _conv(x, w, b, strides, padding):
    kh, kw, _, cout = w.shape
    sh, sw = strides[1], strides[2]
    if padding == "SAME":
        (t, bo), (le, r) = _same(x.shape[1], kh, sh), _same(x.shape[2], kw, sw)
        x = np.pad(x, [(0, 0), (t, bo), (le, r), (0, 0)])
    oh, ow = (x.shape[1] - kh) // sh + 1, (x.shape[2] - kw) // sw + 1
    y = np.zeros((x.shape[0], oh, ow, cout), np.float64)
    for i in range(kh):
        for j in range(kw):
            patch = x[:, i:i + sh * (oh - 1) + 1:sh, j:j + sw * (ow - 1) + 1:sw, :]
            y += patch.astype(np.float64) @ w[i, j].astype(np.float64)
    return y + b


def _maxpool(x, ksize, strides, padding):
    kh, kw, sh, sw = ksize[1], ksize[2], strides[1], strides[2]
    if padding == "SAME":
        (t, bo), (le, r) = _same(x.shape[1], kh, sh), _same(x.shape[2], kw, sw)
        x = np.pad(x, [(0, 0), (t, bo), (le, r), (0, 0)], constant_values=-np.inf)
    oh, ow = (x.shape[1] - kh) // sh + 1, (x.shape[2] - kw) // sw + 1
    y = np.full((x.shape[0], oh, ow, x.shape[3]), -np.inf)
    for i in range(kh):
        for j in range(kw):
            y = np.maximum(y, x[:, i:i + sh * (oh - 1) + 1:sh, j:j + sw * (ow - 1) + 1:sw, :])
    return y


def _resize_nearest(x, size, half_pixel):
    h, w = x.shape[1], x.shape[2]
    oy, ox = np.arange(size[0]), np.arange(size[1])
    offset = 0.5 if half_pixel else 0.0
    iy = np.minimum(np.floor((oy + offset) * h / size[0]).astype(int), h - 1)
    ix = np.minimum(np.floor((ox + offset) * w / size[1]).astype(int), w - 1)
    return x[:, iy][:, :, ix]


def _strided_slice(x, begin, end, strides, node):
    masks = {k: _attr(node, k + "_mask", 0) for k in ("begin", "end", "ellipsis", "new_axis", "shrink_axis")}
    assert masks["new_axis"] == 0 and masks["shrink_axis"] == 0
    index = []
    for i in range(len(begin)):
        if masks["ellipsis"] >> i & 1:
            index.append(Ellipsis)
            continue
        b = None if masks["begin"] >> i & 1 else int(begin[i])
        e = None if masks["end"] >> i & 1 else int(end[i])
        index.append(slice(b, e, int(strides[i])))
    return x[tuple(index)]


class Reference:
    """Evaluates a TF.js graph model with numpy, in float64, NHWC."""

    def __init__(self, model_json):
        with open(model_json) as f:
            model = json.load(f)
        directory = os.path.dirname(model_json)
        self.values = {}
        for group in model["weightsManifest"]:
            data = b"".join(open(os.path.join(directory, p), "rb").read() for p in group["paths"])
            offset = 0
            for spec in group["weights"]:
                dtype = np.dtype(spec["dtype"])
                count = int(np.prod(spec["shape"]))
                self.values[spec["name"]] = np.frombuffer(data, dtype, count, offset).reshape(spec["shape"])
                offset += count * dtype.itemsize
        self.nodes = {n["name"]: n for n in model["modelTopology"]["node"]}
        self.native = None

    def run(self, image, outputs=("Identity",), keep_resize_factor=False):
        """The values of `outputs` for `image` (1 x H x W x 3, RGB in [0, 1]). keep_resize_factor:
        the upsamplings keep the factor they have at the graph's own input size instead of their
        baked output size (for the backbone at another input size)."""
        if keep_resize_factor and self.native is None:
            self.native = {}
            native = self.run(np.zeros((1, SIZE, SIZE, 3)), [n for n, v in self.nodes.items()
                                                             if v["op"] == "ResizeNearestNeighbor"])
            for name, value in native.items():
                source = self.nodes[name]["input"][0]
                self.native[name] = value.shape[1] // self._shapes[source][1]
        cache = {"input_1": np.asarray(image, np.float64)}
        self._shapes = {}
        for name in outputs:
            self._eval(name, cache, keep_resize_factor)
        return {name: cache[name] for name in outputs}

    def _eval(self, name, cache, keep_resize_factor):
        if name in cache:
            return cache[name]
        if name in self.values:
            return self.values[name]
        node = self.nodes[name]
        args = [self._eval(i, cache, keep_resize_factor) for i in node.get("input", [])]
        op = node["op"]
        if op == "Identity":
            y = args[0]
        elif op == "_FusedConv2D":
            y = _conv(args[0], args[1], args[2], _attr(node, "strides"), _attr(node, "padding"))
        elif op == "Sigmoid":
            y = 1.0 / (1.0 + np.exp(-args[0]))
        elif op == "Mul":
            y = args[0] * args[1]
        elif op in ("Add", "AddV2"):
            y = args[0] + args[1]
        elif op == "Square":
            y = np.square(args[0])
        elif op == "Pad":
            y = np.pad(args[0], args[1].tolist())
        elif op == "MaxPool":
            y = _maxpool(args[0], _attr(node, "ksize"), _attr(node, "strides"), _attr(node, "padding"))
        elif op == "ConcatV2":
            y = np.concatenate(args[:-1], axis=int(args[-1]))
        elif op == "ResizeNearestNeighbor":
            size = args[1].tolist()
            if keep_resize_factor:
                size = [args[0].shape[1] * self.native[name], args[0].shape[2] * self.native[name]]
            y = _resize_nearest(args[0], size, _attr(node, "half_pixel_centers", False))
        elif op == "Reshape":
            y = args[0].reshape(args[1].tolist())
        elif op == "Transpose":
            y = args[0].transpose(args[1].tolist())
        elif op == "StridedSlice":
            y = _strided_slice(args[0], args[1], args[2], args[3], node)
        else:
            raise NotImplementedError(op)
        cache[name] = y
        self._shapes[name] = y.shape
        return y


def decode_head(raw, stride):
    """YOLOv5's box decoding of one head's raw convolution output (1 x ny x nx x 3 * COLUMNS), in
    input pixels: rows ordered anchor by anchor, cells row-major, as the TF export orders them."""
    _, ny, nx, _ = raw.shape
    p = 1.0 / (1.0 + np.exp(-raw.reshape(ny, nx, 3, COLUMNS)))
    gx, gy = np.meshgrid(np.arange(nx), np.arange(ny))
    rows = []
    for a, (aw, ah) in enumerate(ANCHORS[stride]):
        q = p[:, :, a, :]
        cx = (q[..., 0] * 2 - 0.5 + gx) * stride
        cy = (q[..., 1] * 2 - 0.5 + gy) * stride
        w = (q[..., 2] * 2) ** 2 * aw
        h = (q[..., 3] * 2) ** 2 * ah
        rows.append(np.concatenate([np.stack([cx, cy, w, h], -1), q[..., 4:]], -1).reshape(ny * nx, COLUMNS))
    return np.concatenate(rows, 0)
