#include "packed_linear.h"

#include <ATen/Parallel.h>

#include <cstdint>
#include <cstring>
#include <map>
#include <mutex>
#include <vector>

#include "format/input_error.h"
#include "gru_inference.h"
#include "vector_clones.h"

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

}  // namespace

struct PackedLinear::Impl {
  // The product for one number of rows.
  struct Product {
    dnnl::matmul matmul;
    memory::desc src, dst, scratchpad;
  };

  memory::dim n, k;
  Type type;
  memory::desc bias_desc, packed_desc;
  memory packed_weight, bias;
  std::mutex products_mutex;
  std::map<memory::dim, std::shared_ptr<const Product>> products;

  dnnl::primitive_attr attributes() const {
    dnnl::primitive_attr attr;
    attr.set_scratchpad_mode(dnnl::scratchpad_mode::user);  // per-thread scratch: concurrent calls are safe
    return attr;
  }

  dnnl::matmul::primitive_desc describe(memory::dim rows, const memory::desc& weights) const {
    return dnnl::matmul::primitive_desc(
        dnnl::matmul::desc(memory::desc({rows, k}, type, Tag::ab), weights, bias_desc,
                           memory::desc({rows, n}, Type::f32, Tag::ab)),
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
    throw InputError(std::string("precision: ") + precision_name(precision) + " is not available on this CPU");
  }
  auto& m = *impl_;
  m.n = weight.size(0);
  m.k = weight.size(1);
  m.type = precision == Precision::kBf16 ? Type::bf16 : Type::f32;
  m.bias_desc = memory::desc({1, m.n}, Type::f32, Tag::ab);
  m.packed_desc = m.describe(kPackingRows, memory::desc({m.k, m.n}, m.type, Tag::any)).weights_desc();
  // The weight (N, K) row-major is W^T (K, N) in column-major order: "ba".
  const auto source = weight.detach().to(at::kFloat).contiguous();
  memory plain(memory::desc({m.k, m.n}, Type::f32, Tag::ba), cpu_engine(), source.data_ptr<float>());
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
  void* source = input.data_ptr<float>();
  if (impl_->type == Type::bf16) {
    auto& converted = scratch(1, product->src.get_size());
    to_bf16(input.data_ptr<float>(), reinterpret_cast<uint16_t*>(converted.data()), rows * impl_->k);
    source = converted.data();
  }
  memory src(product->src, engine, source);
  memory dst(product->dst, engine, out.data_ptr<float>());
  memory scratchpad(product->scratchpad, engine, scratch(0, product->scratchpad.get_size()).data());
  product->matmul.execute(stream, {{DNNL_ARG_SRC, src},
                                   {DNNL_ARG_WEIGHTS, impl_->packed_weight},
                                   {DNNL_ARG_BIAS, impl_->bias},
                                   {DNNL_ARG_DST, dst},
                                   {DNNL_ARG_SCRATCHPAD, scratchpad}});
  stream.wait();
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
    throw InputError(std::string("precision: ") + precision_name(precision) +
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
