#include "grid_vision_fusion/detection/winograd_convolution.h"

#include <immintrin.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/dnn/all_layers.hpp>
#include <opencv2/dnn/layer.hpp>
#include <opencv2/dnn/shape_utils.hpp>

#include <algorithm>
#include <cstddef>
#include <mutex>
#include <vector>

namespace grid_vision_fusion
{
namespace
{
constexpr int kPositions = 16;   ///< values of a transformed 4 × 4 tile
constexpr int kMr = 6;           ///< output channels per micro-kernel call
constexpr int kNr = 16;          ///< tiles per micro-kernel call (two 8-float vectors)
constexpr int kBlockTiles = 64;  ///< tiles one task transforms and multiplies together
constexpr int kGroups = kBlockTiles / kNr;

/// Shapes of one layer on one input.
struct Geometry
{
  int channels = 0;  ///< C, input channels
  int outputs = 0;   ///< K, output channels
  int panels = 0;    ///< ceil(K / kMr)
  int height = 0, width = 0;
  int out_height = 0, out_width = 0;
  int pad_top = 0, pad_left = 0;
  int tiles_y = 0, tiles_x = 0;
  int tiles() const { return tiles_y * tiles_x; }
};

/// The transformed kernels U = G g Gᵀ of every (output k, input c) pair, laid out for the
/// micro-kernel: [position][panel of kMr outputs][c][kMr], outputs beyond K zero.
/// G = [1 0 0; ½ ½ ½; ½ −½ ½; 0 0 1].
std::vector<float> transformKernels(const cv::Mat& weights, int outputs, int channels)
{
  const int panels = (outputs + kMr - 1) / kMr;
  std::vector<float> u(static_cast<std::size_t>(kPositions) * panels * channels * kMr, 0.F);
  for (int k = 0; k < outputs; ++k)
  {
    const float* row = weights.ptr<float>(k);
    for (int c = 0; c < channels; ++c)
    {
      const float* g = row + c * 9;
      float gg[4][3];  // G g
      for (int j = 0; j < 3; ++j)
      {
        gg[0][j] = g[j];
        gg[1][j] = 0.5F * (g[j] + g[3 + j] + g[6 + j]);
        gg[2][j] = 0.5F * (g[j] - g[3 + j] + g[6 + j]);
        gg[3][j] = g[6 + j];
      }
      for (int i = 0; i < 4; ++i)
      {
        const float t[4] = {gg[i][0], 0.5F * (gg[i][0] + gg[i][1] + gg[i][2]),
                            0.5F * (gg[i][0] - gg[i][1] + gg[i][2]), gg[i][2]};
        for (int j = 0; j < 4; ++j)
        {
          const std::size_t pos = static_cast<std::size_t>(4 * i + j);
          u[((pos * panels + k / kMr) * channels + c) * kMr + k % kMr] = t[j];
        }
      }
    }
  }
  return u;
}

/// The even and the odd elements of the 16 floats lo, hi.
__attribute__((target("avx2,fma"))) inline void deinterleave(__m256 lo, __m256 hi, __m256& even, __m256& odd)
{
  even = _mm256_castpd_ps(
      _mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(2, 0, 2, 0))), 0xD8));
  odd = _mm256_castpd_ps(
      _mm256_permute4x64_pd(_mm256_castps_pd(_mm256_shuffle_ps(lo, hi, _MM_SHUFFLE(3, 1, 3, 1))), 0xD8));
}

/// V = Bᵀ d B of the 4 × 4 input tiles [first, first + count) of every channel, laid out
/// [position][group of kNr tiles][c][kNr]; lanes beyond `count` are zero.
/// Bᵀ = [1 0 −1 0; 0 1 1 0; 0 −1 1 0; 0 1 0 −1].
/// Eight neighbouring tiles of one tile row that lie inside the image go together: their inputs
/// are 18 consecutive floats per row, the columns of the tiles the even and odd ones of them.
__attribute__((target("avx2,fma"))) void transformInputs(const float* x, const Geometry& geo, int first,
                                                         int count, float* v)
{
  const int channels = geo.channels;
  const std::size_t ps = static_cast<std::size_t>(kGroups) * channels * kNr;  // position stride
  if (count < kBlockTiles)
  {
    std::fill(v, v + kPositions * ps, 0.F);
  }
  const std::size_t plane = static_cast<std::size_t>(geo.height) * geo.width;
  const std::size_t width = static_cast<std::size_t>(geo.width);
  for (int tt = 0; tt < count;)
  {
    const int tile = first + tt;
    const int tx = tile % geo.tiles_x;
    const int y0 = 2 * (tile / geo.tiles_x) - geo.pad_top;
    const int x0 = 2 * tx - geo.pad_left;
    float* out = v + (static_cast<std::size_t>(tt / kNr) * channels) * kNr + tt % kNr;
    if (tt % kNr + 8 <= kNr && tt + 8 <= count && tx + 8 <= geo.tiles_x && y0 >= 0 && y0 + 4 <= geo.height &&
        x0 >= 0 && x0 + 18 <= geo.width)
    {
      for (int c = 0; c < channels; ++c, out += kNr)
      {
        const float* src = x + c * plane + static_cast<std::size_t>(y0) * width + x0;
        __m256 w[4][4];  // [window: x0, x0 + 8, x0 + 2, x0 + 10][row]
        for (int i = 0; i < 4; ++i)
        {
          const float* row = src + i * width;
          w[0][i] = _mm256_loadu_ps(row);
          w[1][i] = _mm256_loadu_ps(row + 8);
          w[2][i] = _mm256_loadu_ps(row + 2);
          w[3][i] = _mm256_loadu_ps(row + 10);
        }
        __m256 r[4][4];  // Bᵀ d of every window: [window][row]
        for (int q = 0; q < 4; ++q)
        {
          r[q][0] = _mm256_sub_ps(w[q][0], w[q][2]);
          r[q][1] = _mm256_add_ps(w[q][1], w[q][2]);
          r[q][2] = _mm256_sub_ps(w[q][2], w[q][1]);
          r[q][3] = _mm256_sub_ps(w[q][1], w[q][3]);
        }
        for (int i = 0; i < 4; ++i)
        {
          __m256 c0, c1, c2, c3;  // tile columns 0..3 of the eight tiles
          deinterleave(r[0][i], r[1][i], c0, c1);
          deinterleave(r[2][i], r[3][i], c2, c3);
          float* dst = out + static_cast<std::size_t>(4 * i) * ps;
          _mm256_storeu_ps(dst, _mm256_sub_ps(c0, c2));
          _mm256_storeu_ps(dst + ps, _mm256_add_ps(c1, c2));
          _mm256_storeu_ps(dst + 2 * ps, _mm256_sub_ps(c2, c1));
          _mm256_storeu_ps(dst + 3 * ps, _mm256_sub_ps(c1, c3));
        }
      }
      tt += 8;
      continue;
    }
    for (int c = 0; c < channels; ++c, out += kNr)
    {
      const float* src = x + c * plane;
      float d[4][4];
      for (int i = 0; i < 4; ++i)
      {
        const int yy = y0 + i;
        for (int j = 0; j < 4; ++j)
        {
          const int xx = x0 + j;
          d[i][j] = yy >= 0 && yy < geo.height && xx >= 0 && xx < geo.width ? src[yy * width + xx] : 0.F;
        }
      }
      float r[4][4];  // Bᵀ d
      for (int j = 0; j < 4; ++j)
      {
        r[0][j] = d[0][j] - d[2][j];
        r[1][j] = d[1][j] + d[2][j];
        r[2][j] = d[2][j] - d[1][j];
        r[3][j] = d[1][j] - d[3][j];
      }
      for (int i = 0; i < 4; ++i)
      {
        float* dst = out + static_cast<std::size_t>(4 * i) * ps;
        dst[0] = r[i][0] - r[i][2];
        dst[ps] = r[i][1] + r[i][2];
        dst[2 * ps] = r[i][2] - r[i][1];
        dst[3 * ps] = r[i][1] - r[i][3];
      }
    }
    ++tt;
  }
}

/// C[kMr × kNr] = A[kMr × channels] · B[channels × kNr]; A is stored [c][kMr], B [c][kNr], C row
/// by row with stride `ldc`. The twelve accumulators are written out one by one on purpose: as an
/// array `__m256 acc[6][2]` with loops (even with `#pragma GCC unroll`) GCC 12 kept them on the
/// stack, and the Winograd layers of yolov3-416 took 371–424 instead of 220 ms.
__attribute__((target("avx2,fma"))) void multiplyPanel(const float* a, const float* b, int channels, float* c,
                                                       int ldc)
{
  __m256 c00 = _mm256_setzero_ps(), c01 = _mm256_setzero_ps(), c10 = _mm256_setzero_ps(),
         c11 = _mm256_setzero_ps(), c20 = _mm256_setzero_ps(), c21 = _mm256_setzero_ps(),
         c30 = _mm256_setzero_ps(), c31 = _mm256_setzero_ps(), c40 = _mm256_setzero_ps(),
         c41 = _mm256_setzero_ps(), c50 = _mm256_setzero_ps(), c51 = _mm256_setzero_ps();
  for (int k = 0; k < channels; ++k, a += kMr, b += kNr)
  {
    const __m256 b0 = _mm256_loadu_ps(b);
    const __m256 b1 = _mm256_loadu_ps(b + 8);
    __m256 s = _mm256_broadcast_ss(a);
    c00 = _mm256_fmadd_ps(s, b0, c00);
    c01 = _mm256_fmadd_ps(s, b1, c01);
    s = _mm256_broadcast_ss(a + 1);
    c10 = _mm256_fmadd_ps(s, b0, c10);
    c11 = _mm256_fmadd_ps(s, b1, c11);
    s = _mm256_broadcast_ss(a + 2);
    c20 = _mm256_fmadd_ps(s, b0, c20);
    c21 = _mm256_fmadd_ps(s, b1, c21);
    s = _mm256_broadcast_ss(a + 3);
    c30 = _mm256_fmadd_ps(s, b0, c30);
    c31 = _mm256_fmadd_ps(s, b1, c31);
    s = _mm256_broadcast_ss(a + 4);
    c40 = _mm256_fmadd_ps(s, b0, c40);
    c41 = _mm256_fmadd_ps(s, b1, c41);
    s = _mm256_broadcast_ss(a + 5);
    c50 = _mm256_fmadd_ps(s, b0, c50);
    c51 = _mm256_fmadd_ps(s, b1, c51);
  }
  _mm256_storeu_ps(c, c00);
  _mm256_storeu_ps(c + 8, c01);
  _mm256_storeu_ps(c + ldc, c10);
  _mm256_storeu_ps(c + ldc + 8, c11);
  _mm256_storeu_ps(c + 2 * ldc, c20);
  _mm256_storeu_ps(c + 2 * ldc + 8, c21);
  _mm256_storeu_ps(c + 3 * ldc, c30);
  _mm256_storeu_ps(c + 3 * ldc + 8, c31);
  _mm256_storeu_ps(c + 4 * ldc, c40);
  _mm256_storeu_ps(c + 4 * ldc + 8, c41);
  _mm256_storeu_ps(c + 5 * ldc, c50);
  _mm256_storeu_ps(c + 5 * ldc + 8, c51);
}

/// The fused output stage: bias, then ReLU with the given negative slope when `relu`.
struct OutputStage
{
  const float* bias = nullptr;
  bool relu = false;
  float slope = 0.F;
  float apply(float value, int k) const
  {
    value += bias[k];
    return relu && value < 0.F ? value * slope : value;
  }
};

/// Y = Aᵀ m A for output channels [k_first, k_last) of the tiles [first, first + count), with
/// Aᵀ = [1 1 1 0; 0 1 −1 −1]; m is laid out [position][k − k_first][kBlockTiles], one position
/// `position_stride` floats after the other. Eight neighbouring tiles of one tile row whose outputs
/// lie inside the image go together (two rows of 16 consecutive outputs).
__attribute__((target("avx2,fma"))) void transformOutputs(const float* m, std::size_t position_stride,
                                                          int k_first, int k_last, const OutputStage& stage,
                                                          const Geometry& geo, int first, int count, float* y)
{
  const std::size_t ps = position_stride;
  const std::size_t plane = static_cast<std::size_t>(geo.out_height) * geo.out_width;
  const std::size_t width = static_cast<std::size_t>(geo.out_width);
  const __m256 zero = _mm256_setzero_ps();
  const __m256 slope = _mm256_set1_ps(stage.slope);
  for (int k = k_first; k < k_last; ++k)
  {
    const float* row = m + static_cast<std::size_t>(k - k_first) * kBlockTiles;
    float* dst = y + k * plane;
    const __m256 bias = _mm256_set1_ps(stage.bias[k]);
    for (int tt = 0; tt < count;)
    {
      const int tile = first + tt;
      const int oy = 2 * (tile / geo.tiles_x);
      const int tx = tile % geo.tiles_x;
      const int ox = 2 * tx;
      if (tt + 8 <= count && tx + 8 <= geo.tiles_x && oy + 2 <= geo.out_height && ox + 16 <= geo.out_width)
      {
        __m256 s[2][4];
        for (int j = 0; j < 4; ++j)
        {
          const __m256 m0 = _mm256_loadu_ps(row + j * ps + tt);
          const __m256 m1 = _mm256_loadu_ps(row + (4 + j) * ps + tt);
          const __m256 m2 = _mm256_loadu_ps(row + (8 + j) * ps + tt);
          const __m256 m3 = _mm256_loadu_ps(row + (12 + j) * ps + tt);
          s[0][j] = _mm256_add_ps(_mm256_add_ps(m0, m1), m2);
          s[1][j] = _mm256_sub_ps(_mm256_sub_ps(m1, m2), m3);
        }
        for (int i = 0; i < 2; ++i)
        {
          __m256 left = _mm256_add_ps(_mm256_add_ps(_mm256_add_ps(s[i][0], s[i][1]), s[i][2]), bias);
          __m256 right = _mm256_add_ps(_mm256_sub_ps(_mm256_sub_ps(s[i][1], s[i][2]), s[i][3]), bias);
          if (stage.relu)
          {
            left = _mm256_blendv_ps(left, _mm256_mul_ps(left, slope), _mm256_cmp_ps(left, zero, _CMP_LT_OQ));
            right =
                _mm256_blendv_ps(right, _mm256_mul_ps(right, slope), _mm256_cmp_ps(right, zero, _CMP_LT_OQ));
          }
          const __m256 lo = _mm256_unpacklo_ps(left, right);
          const __m256 hi = _mm256_unpackhi_ps(left, right);
          float* out = dst + (oy + i) * width + ox;
          _mm256_storeu_ps(out, _mm256_permute2f128_ps(lo, hi, 0x20));
          _mm256_storeu_ps(out + 8, _mm256_permute2f128_ps(lo, hi, 0x31));
        }
        tt += 8;
        continue;
      }
      float s[2][4];
      for (int j = 0; j < 4; ++j)
      {
        const float m0 = row[j * ps + tt];
        const float m1 = row[(4 + j) * ps + tt];
        const float m2 = row[(8 + j) * ps + tt];
        const float m3 = row[(12 + j) * ps + tt];
        s[0][j] = m0 + m1 + m2;
        s[1][j] = m1 - m2 - m3;
      }
      for (int i = 0; i < 2 && oy + i < geo.out_height; ++i)
      {
        float* out = dst + (oy + i) * width + ox;
        out[0] = stage.apply(s[i][0] + s[i][1] + s[i][2], k);
        if (ox + 1 < geo.out_width)
        {
          out[1] = stage.apply(s[i][1] - s[i][2] - s[i][3], k);
        }
      }
      ++tt;
    }
  }
}

/// Scratch memory of one thread, kept between calls (no allocation per layer once grown).
std::vector<float>& scratch(int which)
{
  thread_local std::vector<float> buffers[2];
  return buffers[which];
}

class WinogradConvolutionLayer : public cv::dnn::Layer
{
public:
  WinogradConvolutionLayer(const cv::dnn::LayerParams& params, int pad_top, int pad_bottom, int pad_left,
                           int pad_right)
      : cv::dnn::Layer(params),
        pad_top_(pad_top),
        pad_bottom_(pad_bottom),
        pad_left_(pad_left),
        pad_right_(pad_right)
  {
    type = kWinogradLayerType;
    outputs_ = blobs[0].size[0];
    channels_ = blobs[0].size[1];
    reset();
  }

  bool supportBackend(int backend_id) override { return backend_id == cv::dnn::DNN_BACKEND_OPENCV; }

  bool getMemoryShapes(const std::vector<cv::dnn::MatShape>& inputs, const int /*required_outputs*/,
                       std::vector<cv::dnn::MatShape>& outputs,
                       std::vector<cv::dnn::MatShape>& /*internals*/) const override
  {
    CV_CheckEQ(inputs.size(), static_cast<std::size_t>(1), "the Winograd convolution takes one input");
    const cv::dnn::MatShape& in = inputs[0];
    CV_CheckEQ(in.size(), static_cast<std::size_t>(4),
               "the Winograd convolution takes an N x C x H x W blob");
    CV_CheckEQ(in[1], channels_, "input channels differ from the kernels'");
    outputs.assign(1, cv::dnn::MatShape{in[0], outputs_, in[2] + pad_top_ + pad_bottom_ - 2,
                                        in[3] + pad_left_ + pad_right_ - 2});
    CV_CheckGT(outputs[0][2], 0, "input smaller than the kernel");
    CV_CheckGT(outputs[0][3], 0, "input smaller than the kernel");
    return false;
  }

  /// The direct convolution's count (as OpenCV's layer reports it): the FLOP bound of a network
  /// stays the same whichever layer computes it.
  int64 getFLOPS(const std::vector<cv::dnn::MatShape>& inputs,
                 const std::vector<cv::dnn::MatShape>& outputs) const override
  {
    int64 flops = 0;
    for (std::size_t i = 0; i < outputs.size(); ++i)
    {
      flops += static_cast<int64>(cv::dnn::total(outputs[i])) * (int64{2} * 9 * inputs[0][1] + 1);
    }
    return flops;
  }

  /// Called before every fusion pass: back to the layer's own weights and no activation.
  void finalize(cv::InputArrayOfArrays /*inputs*/, cv::OutputArrayOfArrays /*outputs*/) override { reset(); }

  /// Folds a following per-channel scale and shift (batch normalisation, Scale) into the weights;
  /// not once an activation is fused (the scale would come after it).
  bool tryFuse(cv::Ptr<cv::dnn::Layer>& top) override
  {
    if (stage_relu_)
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
    transformed_.clear();
    return true;
  }

  /// Fuses ReLU and leaky ReLU; other activations stay separate layers.
  bool setActivation(const cv::Ptr<cv::dnn::ActivationLayer>& layer) override
  {
    const cv::Ptr<cv::dnn::ReLULayer> relu = layer.dynamicCast<cv::dnn::ReLULayer>();
    if (relu.empty() || stage_relu_)
    {
      return false;
    }
    stage_relu_ = true;
    stage_slope_ = relu->negativeSlope;
    return true;
  }

  void forward(cv::InputArrayOfArrays inputs_arr, cv::OutputArrayOfArrays outputs_arr,
               cv::OutputArrayOfArrays /*internals*/) override
  {
    std::vector<cv::Mat> inputs, outputs;
    inputs_arr.getMatVector(inputs);
    outputs_arr.getMatVector(outputs);
    CV_CheckEQ(inputs.size(), static_cast<std::size_t>(1), "the Winograd convolution takes one input");
    const cv::Mat& x = inputs[0];
    cv::Mat& y = outputs[0];
    CV_CheckType(x.type(), x.type() == CV_32F, "the Winograd convolution computes in 32-bit float");
    CV_Assert(x.dims == 4 && x.size[1] == channels_ && x.isContinuous() && y.isContinuous());
    if (transformed_.empty())
    {
      transformed_ = transformKernels(weights_, outputs_, channels_);
    }
    Geometry geo;
    geo.channels = channels_;
    geo.outputs = outputs_;
    geo.panels = (outputs_ + kMr - 1) / kMr;
    geo.height = x.size[2];
    geo.width = x.size[3];
    geo.out_height = y.size[2];
    geo.out_width = y.size[3];
    geo.pad_top = pad_top_;
    geo.pad_left = pad_left_;
    geo.tiles_y = (geo.out_height + 1) / 2;
    geo.tiles_x = (geo.out_width + 1) / 2;
    const OutputStage stage{bias_.data(), stage_relu_, stage_slope_};

    // Tasks: blocks of kBlockTiles tiles; where there are too few blocks to keep every thread
    // busy (the 13 × 13 layers of YOLOv3), the output channels are split as well.
    const int blocks = (geo.tiles() + kBlockTiles - 1) / kBlockTiles;
    const int threads = std::max(1, cv::getNumThreads());
    const int splits = std::min(geo.panels, std::max(1, (4 * threads + blocks - 1) / blocks));
    const int panels_per_split = (geo.panels + splits - 1) / splits;
    const int tasks = blocks * splits;
    const std::size_t in_image = x.total() / static_cast<std::size_t>(x.size[0]);
    const std::size_t out_image = y.total() / static_cast<std::size_t>(y.size[0]);
    for (int n = 0; n < x.size[0]; ++n)
    {
      const float* xin = x.ptr<float>() + n * in_image;
      float* yout = y.ptr<float>() + n * out_image;
      cv::parallel_for_(
          cv::Range(0, tasks),
          [&](const cv::Range& range)
          {
            for (int task = range.start; task < range.end; ++task)
            {
              const int block = task / splits;
              const int p_first = (task % splits) * panels_per_split;
              const int p_last = std::min(geo.panels, p_first + panels_per_split);
              if (p_first < p_last)
              {
                runTask(xin, geo, stage, block, p_first, p_last, yout);
              }
            }
          },
          tasks);
    }
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
    stage_relu_ = false;
    stage_slope_ = 0.F;
    transformed_.clear();
  }

  /// One block of tiles, output panels [p_first, p_last): input transform, 16 products, output
  /// transform straight into the output blob.
  void runTask(const float* x, const Geometry& geo, const OutputStage& stage, int block, int p_first,
               int p_last, float* y) const
  {
    const int first = block * kBlockTiles;
    const int count = std::min(kBlockTiles, geo.tiles() - first);
    const int groups = (count + kNr - 1) / kNr;
    const std::size_t v_position = static_cast<std::size_t>(kGroups) * geo.channels * kNr;
    const int rows = (p_last - p_first) * kMr;
    const std::size_t m_position = static_cast<std::size_t>(rows) * kBlockTiles;
    std::vector<float>& v = scratch(0);
    std::vector<float>& m = scratch(1);
    v.resize(kPositions * v_position);
    m.resize(kPositions * m_position);
    transformInputs(x, geo, first, count, v.data());
    for (int pos = 0; pos < kPositions; ++pos)
    {
      for (int p = p_first; p < p_last; ++p)
      {
        const float* a =
            transformed_.data() + ((static_cast<std::size_t>(pos) * geo.panels + p) * geo.channels) * kMr;
        float* c = m.data() + pos * m_position + static_cast<std::size_t>((p - p_first) * kMr) * kBlockTiles;
        for (int g = 0; g < groups; ++g)
        {
          multiplyPanel(a, v.data() + pos * v_position + static_cast<std::size_t>(g) * geo.channels * kNr,
                        geo.channels, c + g * kNr, kBlockTiles);
        }
      }
    }
    transformOutputs(m.data(), m_position, p_first * kMr, std::min(geo.outputs, p_last * kMr), stage, geo,
                     first, count, y);
  }

  int pad_top_, pad_bottom_, pad_left_, pad_right_;
  int outputs_ = 0;
  int channels_ = 0;
  cv::Mat weights_;  ///< K × (C · 9), batch normalisation folded in
  std::vector<float> bias_;
  bool stage_relu_ = false;
  float stage_slope_ = 0.F;
  std::vector<float> transformed_;  ///< transformKernels(weights_), made at the first forward pass
};

/// The factory registered for "Convolution": the Winograd layer where it applies, OpenCV's own
/// convolution everywhere else.
cv::Ptr<cv::dnn::Layer> createConvolution(cv::dnn::LayerParams& params)
{
  cv::Ptr<cv::dnn::BaseConvolutionLayer> own = cv::dnn::ConvolutionLayer::create(params);
  const auto is = [](const std::vector<std::size_t>& values, std::size_t expected)
  { return values.size() == 2 && values[0] == expected && values[1] == expected; };
  const bool eligible =
      is(own->kernel_size, 3) && is(own->strides, 1) && is(own->dilations, 1) && own->padMode.empty() &&
      own->pads_begin.size() == 2 && own->pads_end.size() == 2 && params.get<int>("group", 1) == 1 &&
      (params.blobs.size() == 1 || params.blobs.size() == 2) && params.blobs[0].type() == CV_32F &&
      params.blobs[0].dims == 4 && params.blobs[0].size[1] >= kMinInputChannels &&
      (params.blobs.size() == 1 || (params.blobs[1].type() == CV_32F &&
                                    static_cast<int>(params.blobs[1].total()) == params.blobs[0].size[0]));
  if (!eligible)
  {
    return own;
  }
  return cv::makePtr<WinogradConvolutionLayer>(
      params, static_cast<int>(own->pads_begin[0]), static_cast<int>(own->pads_end[0]),
      static_cast<int>(own->pads_begin[1]), static_cast<int>(own->pads_end[1]));
}

std::mutex g_scope_mutex;
int g_scope_count = 0;

}  // namespace

bool winogradSupported()
{
  return cv::checkHardwareSupport(CV_CPU_AVX2) && cv::checkHardwareSupport(CV_CPU_FMA3);
}

WinogradConvolutionScope::WinogradConvolutionScope(bool enable)
{
  if (!enable || !winogradSupported())
  {
    return;
  }
  const std::lock_guard<std::mutex> lock(g_scope_mutex);
  if (g_scope_count++ == 0)
  {
    cv::dnn::LayerFactory::registerLayer("Convolution", createConvolution);
  }
  active_ = true;
}

WinogradConvolutionScope::~WinogradConvolutionScope()
{
  if (!active_)
  {
    return;
  }
  const std::lock_guard<std::mutex> lock(g_scope_mutex);
  if (--g_scope_count == 0)
  {
    cv::dnn::LayerFactory::unregisterLayer("Convolution");
  }
}

}  // namespace grid_vision_fusion
