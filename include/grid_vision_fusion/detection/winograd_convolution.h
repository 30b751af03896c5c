// A 3 × 3 stride-1 convolution for OpenCV's DNN module computed with Winograd's minimal filtering
// algorithm F(2 × 2, 3 × 3) (Lavin & Gray, "Fast Algorithms for Convolutional Neural Networks",
// CVPR 2016): each 4 × 4 input tile is transformed once, the 3 × 3 kernels are transformed once,
// and the 2 × 2 output tile is recovered from 16 products per input channel instead of 36 — 2.25 ×
// fewer multiplications than the direct convolution. OpenCV 4.6 (Debian 12) has no Winograd path
// of its own (4.7 added one), and these layers are about three quarters of YOLOv3's time.
//
// The layer replaces OpenCV's "Convolution" layer while a WinogradConvolutionScope is alive: the
// network is created and allocated then (OpenCV instantiates layers at the first forward pass),
// and keeps its layers afterwards. Layers it cannot compute (other kernel sizes, strides,
// dilations, groups, fewer than kMinInputChannels input channels, a CPU without AVX2 and FMA)
// are OpenCV's own. Batch normalisation and ReLU / leaky ReLU that follow the convolution are
// fused into it as OpenCV fuses them into its own. Results equal the direct convolution's up to
// float rounding (the transforms add and subtract inputs before the products; the tests allow
// 1e-5 of the output range).
#pragma once

#include <opencv2/dnn.hpp>

namespace grid_vision_fusion
{
/// The type name the Winograd layers report (cv::dnn::Layer::type), e.g. in per-layer profiles.
constexpr const char* kWinogradLayerType = "WinogradConvolution";

/// Convolutions with fewer input channels stay OpenCV's: the transforms would cost more than the
/// products they save (e.g. a network's first layer on the 3 colour channels).
constexpr int kMinInputChannels = 8;

/// Whether this CPU can run the Winograd layer (AVX2 and FMA).
bool winogradSupported();

/// While alive, OpenCV DNN networks built and first run on any thread of the process compute
/// their eligible 3 × 3 stride-1 convolutions with the Winograd layer. Scopes nest and may live on
/// several threads at once; the layer stays registered until the last one ends. With `enable`
/// false (or on a CPU without AVX2/FMA) the scope does nothing.
class WinogradConvolutionScope
{
public:
  explicit WinogradConvolutionScope(bool enable = true);
  ~WinogradConvolutionScope();
  WinogradConvolutionScope(const WinogradConvolutionScope&) = delete;
  WinogradConvolutionScope& operator=(const WinogradConvolutionScope&) = delete;

  /// Whether this scope registered (or shares the registration of) the Winograd layer.
  bool active() const { return active_; }

private:
  bool active_ = false;
};

}  // namespace grid_vision_fusion
