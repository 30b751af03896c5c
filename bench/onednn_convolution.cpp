#include "onednn_convolution.h"

#ifdef GVF_HAVE_ONEDNN

#include <oneapi/dnnl/dnnl.hpp>

#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/dnn/layer.hpp>
#include <opencv2/dnn/shape_utils.hpp>

#include <algorithm>
#include <cstddef>
#include <cstdlib>
#include <mutex>
#include <set>
#include <unordered_map>
#include <vector>

namespace grid_vision_fusion::bench
{
namespace
{
using dnnl::memory;
using Tag = memory::format_tag;
using Type = memory::data_type;

dnnl::engine& engine()
{
  static dnnl::engine cpu(dnnl::engine::kind::cpu, 0);
  return cpu;
}

dnnl::stream& stream()
{
  static dnnl::stream s(engine());
  return s;
}

std::mutex g_implementations_mutex;
std::set<std::string> g_implementations;  ///< oneDNN's names of the implementations it picked

/// The primitive for one input shape, with its weights in the primitive's layout and the
/// reorders between OpenCV's NCHW blobs and the primitive's activation layouts.
struct Compiled
{
  dnnl::convolution_forward conv;
  memory weights, bias;
  memory::desc src_user, dst_user, src_conv, dst_conv;
  memory src_buffer, dst_buffer;  ///< only where the primitive's layout is not NCHW
  dnnl::reorder to_src, from_dst;
};

class OnednnConvolutionLayer : public cv::dnn::Layer
{
public:
  OnednnConvolutionLayer(const cv::dnn::LayerParams& params, std::vector<int> pads)
      : cv::dnn::Layer(params), pads_(std::move(pads))
  {
    type = kOnednnLayerType;
    outputs_ = blobs[0].size[0];
    channels_ = blobs[0].size[1];
    reset();
  }

  bool supportBackend(int backend_id) override { return backend_id == cv::dnn::DNN_BACKEND_OPENCV; }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, const int /*required_outputs*/,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>& /*internals*/) const override
  {
    CV_CheckEQ(inputs.size(), static_cast<std::size_t>(1), "the oneDNN convolution takes one input");
    const cv::dnn::MatShape& in = inputs[0];
    CV_CheckEQ(in.size(), static_cast<std::size_t>(4), "the oneDNN convolution takes an N x C x H x W blob");
    CV_CheckEQ(in[1], channels_, "input channels differ from the kernels'");
    outputs.assign(1, cv::dnn::MatShape{in[0], outputs_, in[2] + pads_[0] + pads_[1] - 2,
                                        in[3] + pads_[2] + pads_[3] - 2});
    return false;
  }

  /// The direct convolution's count, as OpenCV's layer reports it.
  int64 getFLOPS(const std::vector<cv::dnn::MatShape>& inputs,
                 const std::vector<cv::dnn::MatShape>& outputs) const override
  {
    int64 flops = 0;
    for (const cv::dnn::MatShape& output : outputs)
    {
      flops += static_cast<int64>(cv::dnn::total(output)) * (int64{2} * 9 * inputs[0][1] + 1);
    }
    return flops;
  }

  void finalize(cv::InputArrayOfArrays /*inputs*/, cv::OutputArrayOfArrays /*outputs*/) override { reset(); }

  /// Folds a following per-channel scale and shift (batch normalisation) into the weights.
  bool tryFuse(cv::Ptr<cv::dnn::Layer>& top) override
  {
    if (relu_)
    {
      return false;
    }
    cv::Mat scale, shift;
    top->getScaleShift(scale, shift);
    const auto fits = [this](const cv::Mat& m) {
      return m.empty() || (m.type() == CV_32F && static_cast<int>(m.total()) == outputs_ && m.isContinuous());
    };
    if ((scale.empty() && shift.empty()) || !fits(scale) || !fits(shift))
    {
      return false;
    }
    for (int k = 0; k < outputs_; ++k)
    {
      const float s = scale.empty() ? 1.F : scale.ptr<float>()[k];
      weights_.row(k) *= s;
      bias_[static_cast<std::size_t>(k)] =
          bias_[static_cast<std::size_t>(k)] * s + (shift.empty() ? 0.F : shift.ptr<float>()[k]);
    }
    compiled_.clear();
    return true;
  }

  /// ReLU and leaky ReLU become the primitive's post-op; other activations stay layers.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override
  {
    const cv::Ptr<cv::dnn::ReLULayer> relu = layer.dynamicCast<cv::dnn::ReLULayer>();
    if (relu.empty() || relu_)
    {
      return false;
    }
    relu_ = true;
    slope_ = relu->negativeSlope;
    compiled_.clear();
    return true;
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays /*internals*/) override
  {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    const cv::Mat& x = inputs[0];
    cv::Mat& y = outputs[0];
    CV_Assert(x.type() == CV_32F && x.dims == 4 && x.isContinuous() && y.isContinuous());
    Compiled& c = compiled(memory::dims{x.size[0], x.size[1], x.size[2], x.size[3]},
                           memory::dims{y.size[0], y.size[1], y.size[2], y.size[3]});
    memory src(c.src_user, engine(), const_cast<float*>(x.ptr<float>()));
    memory dst(c.dst_user, engine(), y.ptr<float>());
    if (c.src_buffer)
    {
      c.to_src.execute(stream(), src, c.src_buffer);
    }
    c.conv.execute(stream(), {{DNNL_ARG_SRC, c.src_buffer ? c.src_buffer : src},
                              {DNNL_ARG_WEIGHTS, c.weights},
                              {DNNL_ARG_BIAS, c.bias},
                              {DNNL_ARG_DST, c.dst_buffer ? c.dst_buffer : dst}});
    if (c.dst_buffer)
    {
      c.from_dst.execute(stream(), c.dst_buffer, dst);
    }
    stream().wait();
  }

private:
  void reset()
  {
    weights_ = blobs[0].reshape(1, outputs_).clone();
    bias_.assign(static_cast<std::size_t>(outputs_), 0.F);
    if (blobs.size() > 1)
    {
      const float* b = blobs[1].ptr<float>();
      std::copy(b, b + outputs_, bias_.begin());
    }
    relu_ = false;
    slope_ = 0.F;
    compiled_.clear();
  }

  /// The primitive for this input shape, made at its first use.
  Compiled& compiled(const memory::dims& src_dims, const memory::dims& dst_dims)
  {
    const std::string key =
        cv::format("%ldx%ldx%ldx%ld", static_cast<long>(src_dims[0]), static_cast<long>(src_dims[1]),
                   static_cast<long>(src_dims[2]), static_cast<long>(src_dims[3]));
    const auto found = compiled_.find(key);
    if (found != compiled_.end())
    {
      return found->second;
    }
    const memory::dims weight_dims{outputs_, channels_, 3, 3};
    const memory::dims bias_dims{outputs_};
    const dnnl::convolution_forward::desc desc(
        dnnl::prop_kind::forward_inference, dnnl::algorithm::convolution_direct,
        memory::desc(src_dims, Type::f32, Tag::any), memory::desc(weight_dims, Type::f32, Tag::any),
        memory::desc(bias_dims, Type::f32, Tag::x), memory::desc(dst_dims, Type::f32, Tag::any), {1, 1},
        {pads_[0], pads_[2]}, {pads_[1], pads_[3]});
    dnnl::post_ops post_ops;
    if (relu_)
    {
      post_ops.append_eltwise(1.F, dnnl::algorithm::eltwise_relu, slope_, 0.F);
    }
    dnnl::primitive_attr attr;
    attr.set_post_ops(post_ops);
    const dnnl::convolution_forward::primitive_desc pd(desc, attr, engine());
    {
      const std::lock_guard<std::mutex> lock(g_implementations_mutex);
      g_implementations.insert(pd.impl_info_str());
    }

    Compiled c;
    c.conv = dnnl::convolution_forward(pd);
    c.weights = memory(pd.weights_desc(), engine());
    memory user_weights(memory::desc(weight_dims, Type::f32, Tag::oihw), engine(), weights_.ptr<float>());
    dnnl::reorder(user_weights, c.weights).execute(stream(), user_weights, c.weights);
    c.bias = memory(memory::desc(bias_dims, Type::f32, Tag::x), engine());
    std::copy(bias_.begin(), bias_.end(), static_cast<float*>(c.bias.get_data_handle()));
    c.src_user = memory::desc(src_dims, Type::f32, Tag::nchw);
    c.dst_user = memory::desc(dst_dims, Type::f32, Tag::nchw);
    if (pd.src_desc() != c.src_user)
    {
      c.src_buffer = memory(pd.src_desc(), engine());
      c.to_src = dnnl::reorder(memory(c.src_user, engine(), nullptr), c.src_buffer);
    }
    if (pd.dst_desc() != c.dst_user)
    {
      c.dst_buffer = memory(pd.dst_desc(), engine());
      c.from_dst = dnnl::reorder(c.dst_buffer, memory(c.dst_user, engine(), nullptr));
    }
    stream().wait();
    return compiled_.emplace(key, std::move(c)).first->second;
  }

  std::vector<int> pads_;  ///< top, bottom, left, right
  int outputs_ = 0;
  int channels_ = 0;
  cv::Mat weights_;  ///< K × (C · 9), batch normalisation folded in
  std::vector<float> bias_;
  bool relu_ = false;
  float slope_ = 0.F;
  std::unordered_map<std::string, Compiled> compiled_;
};

cv::Ptr<cv::dnn::Layer> createConvolution(cv::dnn::LayerParams& params)
{
  cv::Ptr<cv::dnn::BaseConvolutionLayer> own = cv::dnn::ConvolutionLayer::create(params);
  const auto is = [](const std::vector<std::size_t>& values, std::size_t expected)
  { return values.size() == 2 && values[0] == expected && values[1] == expected; };
  const bool eligible =
      is(own->kernel_size, 3) && is(own->strides, 1) && is(own->dilations, 1) && own->padMode.empty() &&
      own->pads_begin.size() == 2 && own->pads_end.size() == 2 && params.get<int>("group", 1) == 1 &&
      (params.blobs.size() == 1 || params.blobs.size() == 2) && params.blobs[0].type() == CV_32F &&
      params.blobs[0].dims == 4 && params.blobs[0].size[1] >= kOnednnMinInputChannels &&
      (params.blobs.size() == 1 || (params.blobs[1].type() == CV_32F &&
                                    static_cast<int>(params.blobs[1].total()) == params.blobs[0].size[0]));
  if (!eligible)
  {
    return own;
  }
  return cv::makePtr<OnednnConvolutionLayer>(
      params, std::vector<int>{static_cast<int>(own->pads_begin[0]), static_cast<int>(own->pads_end[0]),
                               static_cast<int>(own->pads_begin[1]), static_cast<int>(own->pads_end[1])});
}

const char* isaName(dnnl::cpu_isa isa)
{
  switch (isa)
  {
    case dnnl::cpu_isa::avx2:
      return "avx2";
    case dnnl::cpu_isa::avx512_core:
      return "avx512_core";
    case dnnl::cpu_isa::avx512_core_vnni:
      return "avx512_core_vnni";
    case dnnl::cpu_isa::avx512_core_bf16:
      return "avx512_core_bf16";
    case dnnl::cpu_isa::avx512_core_amx:
      return "avx512_core_amx";
    default:
      return "other";
  }
}

}  // namespace

bool onednnAvailable()
{
  return true;
}

std::string onednnDescription()
{
  const dnnl_version_t* v = dnnl::version();
  const char* wait_policy = std::getenv("OMP_WAIT_POLICY");
  return cv::format("oneDNN %d.%d.%d, OpenMP threads (OMP_WAIT_POLICY=%s), ISA %s", v->major, v->minor,
                    v->patch, wait_policy != nullptr ? wait_policy : "unset",
                    isaName(dnnl::get_effective_cpu_isa()));
}

std::string onednnImplementations()
{
  const std::lock_guard<std::mutex> lock(g_implementations_mutex);
  std::string names;
  for (const std::string& name : g_implementations)
  {
    names += (names.empty() ? "" : ", ") + name;
  }
  return names;
}

OnednnConvolutionScope::OnednnConvolutionScope() : active_(true)
{
  cv::dnn::LayerFactory::registerLayer("Convolution", createConvolution);
}

OnednnConvolutionScope::~OnednnConvolutionScope()
{
  if (active_)
  {
    cv::dnn::LayerFactory::unregisterLayer("Convolution");
  }
}

}  // namespace grid_vision_fusion::bench

#else  // without oneDNN

namespace grid_vision_fusion::bench
{
bool onednnAvailable()
{
  return false;
}

std::string onednnDescription()
{
  return "not built: CMake found no oneDNN (Debian: libdnnl-dev), the /onednn variants are skipped";
}

std::string onednnImplementations()
{
  return "";
}

OnednnConvolutionScope::OnednnConvolutionScope() = default;

OnednnConvolutionScope::~OnednnConvolutionScope() = default;

}  // namespace grid_vision_fusion::bench

#endif
