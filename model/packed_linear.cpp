#include "model/packed_linear.h"

#include <ATen/Parallel.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "format/input_error.h"
#include "model/gru_inference.h"
#include "model/vector_clones.h"

#ifdef MM_HAVE_ONEDNN
#include <omp.h>

#include <oneapi/dnnl/dnnl.hpp>
#endif

namespace mm {

namespace {

// A tensor's in-place change count. Tensors made inside c10::InferenceMode
// (a model loaded there) keep none: they cannot be trained, so their packs
// stay current (-1 for them, which never changes).
int64_t version_of(const at::Tensor& t) { return t.is_inference() ? -1 : t._version(); }

}  // namespace

#ifdef MM_HAVE_ONEDNN

namespace {

using dnnl::memory;
using Tag = memory::format_tag;
using Type = memory::data_type;

const dnnl::engine& cpu_engine() {
  static const dnnl::engine engine(dnnl::engine::kind::cpu, 0);
  return engine;
}

// The layout oneDNN packs the weights in is chosen for a batch; the packed
// weights then serve every batch size (measured: 1 to 4,500 rows).
constexpr memory::dim kPackingRows = 64;

// Per-thread scratch bytes, grown as needed: the scratchpad of a product
// and the bf16 copy of its input. Threads never share them, so concurrent
// apply() calls need no lock around the product.
std::vector<uint8_t>& scratch(int which, size_t bytes) {
  thread_local std::vector<uint8_t> buffers[2];
  auto& buffer = buffers[which];
  if (buffer.size() < bytes) buffer.resize(bytes);
  return buffer;
}

// fp32 to bf16, rounded to nearest even (a NaN stays a quiet NaN), in a loop
// that vectorises: at batch 1 a oneDNN reorder per product cost more than
// this conversion.
MM_VECTOR_CLONES void to_bf16(const float* __restrict from, uint16_t* __restrict to, int64_t count) {
  for (int64_t i = 0; i < count; ++i) {
    uint32_t bits;
    std::memcpy(&bits, &from[i], sizeof bits);
    const uint32_t rounded = (bits + 0x7FFFu + ((bits >> 16) & 1u)) >> 16;
    to[i] = static_cast<uint16_t>((bits & 0x7FFFFFFFu) > 0x7F800000u ? (bits >> 16) | 0x40u : rounded);
  }
}

// int8 products (Precision::kInt8). A row of the input is quantised with its
// own scale, largest |x| / 127, so the hidden state's 8 bits cover its range
// at every step; the weights have one scale per output row, applied by the
// product, and the row's scale and the bias by finish_int8_row.
constexpr float kInt8Largest = 127.0f;

// The largest |x| of a row as float bits: an integer maximum, so the loop
// vectorises (a float one does not without fast-math). A NaN or an infinity
// is at or above 0x7F800000.
MM_VECTOR_CLONES uint32_t largest_magnitude_bits(const float* __restrict row, int64_t count) {
  uint32_t largest = 0;
  for (int64_t i = 0; i < count; ++i) {
    uint32_t bits;
    std::memcpy(&bits, &row[i], sizeof bits);
    largest = std::max(largest, bits & 0x7FFFFFFFu);
  }
  return largest;
}

// x / scale rounded to the nearest integer (|x / scale| <= 127 by the choice
// of scale); adding 1.5 * 2^23 rounds without a call per element.
MM_VECTOR_CLONES void quantise_row(const float* __restrict row, int8_t* __restrict to, int64_t count,
                                   float inverse_scale) {
  constexpr float kRound = 12582912.0f;
  for (int64_t i = 0; i < count; ++i) {
    to[i] = static_cast<int8_t>(static_cast<int32_t>((row[i] * inverse_scale + kRound) - kRound));
  }
}

MM_VECTOR_CLONES void finish_int8_row(float* __restrict out, const float* __restrict bias, int64_t count,
                                      float row_scale) {
  for (int64_t j = 0; j < count; ++j) out[j] = row_scale * out[j] + bias[j];
}

// Rows (rows, k) to int8 at `to`, each row's scale into `scales`. A row
// holding a NaN or an infinity is quantised as zeros with a NaN scale, so
// its output is NaN as fp32's would be.
void quantise_rows(const float* input, int64_t rows, int64_t k, int8_t* to, float* scales) {
  for (int64_t r = 0; r < rows; ++r) {
    const uint32_t bits = largest_magnitude_bits(input + r * k, k);
    float largest;
    std::memcpy(&largest, &bits, sizeof largest);
    if (bits >= 0x7F800000u) {
      std::memset(to + r * k, 0, k);
      scales[r] = std::numeric_limits<float>::quiet_NaN();
    } else if (bits == 0) {  // all zeros (the encoder's first step)
      std::memset(to + r * k, 0, k);
      scales[r] = 0.0f;
    } else {
      scales[r] = largest / kInt8Largest;
      quantise_row(input + r * k, to + r * k, k, kInt8Largest / largest);
    }
  }
}

}  // namespace

struct PackedLinear::Impl {
  // The product for one number of rows.
  struct Product {
    dnnl::matmul matmul;
    memory::desc src, dst, scratchpad;
  };

  memory::dim n, k;
  Type type;
  std::vector<float> weight_scales;  // int8: one per output row
  memory::desc bias_desc, packed_desc;
  memory packed_weight, bias;
  std::mutex products_mutex;
  std::map<memory::dim, std::shared_ptr<const Product>> products;

  dnnl::primitive_attr attributes() const {
    dnnl::primitive_attr attr;
    attr.set_scratchpad_mode(dnnl::scratchpad_mode::user);  // per-thread scratch: concurrent calls are safe
    // The weights' scales are fixed at packing: oneDNN 2.6 runs int8 with
    // its VNNI kernels only for scales known then (runtime ones fell back
    // to a kernel 3.5 times slower at batch 1). The input's scale, one per
    // row and call, is applied after the product.
    if (type == Type::s8) attr.set_output_scales(1 << 1, weight_scales);
    return attr;
  }

  dnnl::matmul::primitive_desc describe(memory::dim rows, const memory::desc& weights) const {
    const memory::desc src({rows, k}, type, Tag::ab), dst({rows, n}, Type::f32, Tag::ab);
    return dnnl::matmul::primitive_desc(
        type == Type::s8 ? dnnl::matmul::desc(src, weights, dst) : dnnl::matmul::desc(src, weights, bias_desc, dst),
        attributes(), cpu_engine());
  }

  std::shared_ptr<const Product> product(memory::dim rows) {
    std::lock_guard<std::mutex> lock(products_mutex);
    auto& slot = products[rows];
    if (!slot) {
      const auto pd = describe(rows, packed_desc);
      auto p = std::make_shared<Product>();
      p->matmul = dnnl::matmul(pd);
      p->src = pd.src_desc();
      p->dst = pd.dst_desc();
      p->scratchpad = pd.scratchpad_desc();
      slot = std::move(p);
    }
    return slot;
  }
};

PackedLinear::PackedLinear(const at::Tensor& weight, const at::Tensor& bias, Precision precision)
    : impl_(std::make_unique<Impl>()),
      precision_(precision),
      weight_(weight),
      bias_(bias),
      weight_version_(version_of(weight)),
      bias_version_(version_of(bias)) {
  if (!precision_available(precision)) {
    throw InputError("precision", std::string("") + precision_name(precision) + " is not available on this CPU");
  }
  auto& m = *impl_;
  m.n = weight.size(0);
  m.k = weight.size(1);
  m.type = precision == Precision::kBf16 ? Type::bf16 : precision == Precision::kInt8 ? Type::s8 : Type::f32;
  m.bias_desc = memory::desc({1, m.n}, Type::f32, Tag::ab);
  // The weight (N, K) row-major is W^T (K, N) in column-major order: "ba".
  auto source = weight.detach().to(at::kFloat).contiguous();
  if (m.type == Type::s8) {
    // Symmetric, one scale per output row: its largest |w| becomes 127.
    auto scales = source.abs().amax(1).div_(kInt8Largest).clamp_min_(std::numeric_limits<float>::min());
    source = source.div(scales.unsqueeze(1)).round_().to(at::kChar).contiguous();
    m.weight_scales.assign(scales.data_ptr<float>(), scales.data_ptr<float>() + m.n);
  }
  m.packed_desc = m.describe(kPackingRows, memory::desc({m.k, m.n}, m.type, Tag::any)).weights_desc();
  memory plain(memory::desc({m.k, m.n}, m.type == Type::s8 ? Type::s8 : Type::f32, Tag::ba), cpu_engine(),
               source.data_ptr());
  m.packed_weight = memory(m.packed_desc, cpu_engine());
  dnnl::stream stream(cpu_engine());
  {
    // Packed on this thread alone: an OpenMP team started here (the thread
    // that loads a model) would stay beside the one inference runs on, and
    // the server's batch-1 decode was measured twice as slow with it.
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    dnnl::reorder(plain, m.packed_weight).execute(stream, plain, m.packed_weight);
    stream.wait();
    omp_set_num_threads(threads);
  }
  m.bias = memory(m.bias_desc, cpu_engine());
  const auto bias_values = bias.detach().to(at::kFloat).contiguous();
  std::memcpy(m.bias.get_data_handle(), bias_values.data_ptr<float>(), sizeof(float) * m.n);
  stream.wait();
}

void PackedLinear::apply(const at::Tensor& input, at::Tensor& out) const {
  const memory::dim rows = input.size(0);
  // One row streams every weight once whatever the layout: the product is
  // bound by memory, and LibTorch's matrix-vector product was measured as
  // fast as the packed one in fp32 (bf16 halves the bytes, so it packs).
  if (rows == 1 && precision_ == Precision::kFp32) {
    affine_into(out, bias_, weight_, input);
    return;
  }
  at::internal::lazy_init_num_threads();  // this thread's OpenMP team as LibTorch sizes it
  const auto product = impl_->product(rows);
  const auto& engine = cpu_engine();
  thread_local dnnl::stream stream(cpu_engine());
  const auto& m = *impl_;
  void* source = input.data_ptr<float>();
  thread_local std::vector<float> row_scales;
  if (m.type == Type::bf16) {
    auto& converted = scratch(1, product->src.get_size());
    to_bf16(input.data_ptr<float>(), reinterpret_cast<uint16_t*>(converted.data()), rows * m.k);
    source = converted.data();
  } else if (m.type == Type::s8) {
    auto& quantised = scratch(1, product->src.get_size());
    row_scales.resize(rows);
    quantise_rows(input.data_ptr<float>(), rows, m.k, reinterpret_cast<int8_t*>(quantised.data()), row_scales.data());
    source = quantised.data();
  }
  memory src(product->src, engine, source);
  memory dst(product->dst, engine, out.data_ptr<float>());
  memory scratchpad(product->scratchpad, engine, scratch(0, product->scratchpad.get_size()).data());
  std::unordered_map<int, memory> arguments{{DNNL_ARG_SRC, src},
                                            {DNNL_ARG_WEIGHTS, m.packed_weight},
                                            {DNNL_ARG_DST, dst},
                                            {DNNL_ARG_SCRATCHPAD, scratchpad}};
  if (m.type != Type::s8) arguments.emplace(DNNL_ARG_BIAS, m.bias);
  product->matmul.execute(stream, arguments);
  stream.wait();
  if (m.type == Type::s8) {  // the product left the bias out: it comes after the row's scale
    const auto* bias = static_cast<const float*>(m.bias.get_data_handle());
    float* rows_out = out.data_ptr<float>();
    for (memory::dim r = 0; r < rows; ++r) finish_int8_row(rows_out + r * m.n, bias, m.n, row_scales[r]);
  }
}

#else  // without oneDNN: LibTorch's products on the source tensors

struct PackedLinear::Impl {};

PackedLinear::PackedLinear(const at::Tensor& weight, const at::Tensor& bias, Precision precision)
    : precision_(precision),
      weight_(weight),
      bias_(bias),
      weight_version_(version_of(weight)),
      bias_version_(version_of(bias)) {
  if (!precision_available(precision)) {
    throw InputError("precision", std::string("") + precision_name(precision) +
                     " is not available in this build (it needs oneDNN)");
  }
}

void PackedLinear::apply(const at::Tensor& input, at::Tensor& out) const { affine_into(out, bias_, weight_, input); }

#endif

PackedLinear::~PackedLinear() = default;

bool PackedLinear::current() const {
  return version_of(weight_) == weight_version_ && version_of(bias_) == bias_version_;
}

}  // namespace mm
