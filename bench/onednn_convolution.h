// bench_yolo only: OpenCV DNN's 3 × 3 stride-1 convolutions computed by oneDNN (Debian's
// libdnnl-dev), to compare with OpenCV's own convolution on whole networks. Not part of the
// package's libraries; built where CMake finds oneDNN (GVF_HAVE_ONEDNN), otherwise the functions
// below say it is missing and the scope does nothing.
//
// While an OnednnConvolutionScope is alive, OpenCV's "Convolution" layers are created by this
// file's factory: a layer with a 3 × 3 kernel, stride 1, dilation 1, one group and at least
// kOnednnMinInputChannels input channels becomes a dnnl::convolution_forward primitive (direct
// algorithm, weights in the layout oneDNN picks for them, reordered once; the activations in
// oneDNN's blocked layout inside the primitive, reordered from and to OpenCV's NCHW blobs at
// every call); every other convolution stays OpenCV's. Batch normalisation and ReLU / leaky ReLU
// after the convolution are fused into it (bias, then the activation as a post-op).
#pragma once

#include <string>

namespace grid_vision_fusion::bench
{
/// The type name the oneDNN layers report (cv::dnn::Layer::type).
constexpr const char* kOnednnLayerType = "OnednnConvolution";

/// Fewer input channels (a network's first layer on three colour channels) stay OpenCV's.
constexpr int kOnednnMinInputChannels = 8;

/// Whether bench_yolo was built with oneDNN.
bool onednnAvailable();

/// oneDNN's version, threading runtime and the instruction set it uses on this CPU; or why the
/// variant is missing.
std::string onednnDescription();

/// The oneDNN implementations the layers made so far run (e.g. "brg:avx512_core"), comma-separated.
std::string onednnImplementations();

/// While alive (and oneDNN is available), networks created and first run compute their eligible
/// convolutions with oneDNN. Not to be nested with other "Convolution" registrations in
/// different orders; one at a time.
class OnednnConvolutionScope
{
public:
  OnednnConvolutionScope();
  ~OnednnConvolutionScope();
  OnednnConvolutionScope(const OnednnConvolutionScope&) = delete;
  OnednnConvolutionScope& operator=(const OnednnConvolutionScope&) = delete;

private:
  bool active_ = false;
};

}  // namespace grid_vision_fusion::bench
