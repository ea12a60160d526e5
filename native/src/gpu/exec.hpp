// The execution layer of the GPU path: the few operations its kernels are
// written in, each with two builds from one source (HOOMD-blue's split of a
// kernel from its launch):
//
//   for_each(n, f)       f(i) for i in [0, n): a <<<blocks, threads>>> launch
//                        under nvcc, a plain OpenMP loop otherwise
//   then(a, b)           a(i) then b(i) as one functor: two passes in one launch
//   DeviceArray<T>       GPU memory (cudaMalloc) under nvcc, a std::vector
//                        otherwise; upload / download copy to and from the host
//   sort_pairs           a stable sort of (key, value) pairs by key:
//                        cub::DeviceRadixSort, or std::stable_sort
//   max_of               the largest element: cub::DeviceReduce::Max, or a loop
//   segment_max          the largest element of each of several consecutive
//                        segments: cub::DeviceSegmentedReduce::Max, or loops
//
// A functor f has a `GRANULAR_HD void operator()(unsigned i) const` and holds
// raw pointers into DeviceArrays (trivially copyable, passed by value to the
// kernel). Everything here lives in the inline namespace gpu::cuda under nvcc
// and gpu::host otherwise, so that both builds of the same kernels link into
// one program without clashing.
#pragma once
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>
#include <vector>

#include "contact/lane.hpp"  // GRANULAR_HD

#if defined(__CUDACC__)
#include <cuda_runtime.h>

#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_reduce.cuh>
#include <cub/device/device_segmented_reduce.cuh>
#define GRANULAR_EXEC_NS cuda
#else
#define GRANULAR_EXEC_NS host
#endif

namespace granular::gpu {
inline namespace GRANULAR_EXEC_NS {

// The name of this build of the kernels, for messages.
#if defined(__CUDACC__)
inline constexpr const char* kBackend = "cuda";

inline void check(cudaError_t e, const char* what) {
  if (e != cudaSuccess) throw std::runtime_error(std::string("CUDA: ") + what + ": " + cudaGetErrorString(e));
}

template <class F>
__global__ void for_each_kernel(unsigned n, F f) {
  const unsigned i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) f(i);
}

// Threads per block: 128 keeps several blocks resident per multiprocessor
// for the register-heavy force kernel.
inline constexpr unsigned kThreads = 128;

template <class F>
void for_each(unsigned n, const F& f) {
  if (n == 0) return;
  for_each_kernel<<<(n + kThreads - 1) / kThreads, kThreads>>>(n, f);
  check(cudaGetLastError(), "kernel launch");
}
#else
inline constexpr const char* kBackend = "host";

template <class F>
void for_each(unsigned n, const F& f) {
#pragma omp parallel for schedule(static)
  for (std::int64_t i = 0; i < static_cast<std::int64_t>(n); ++i) f(static_cast<unsigned>(i));
}
#endif

// first(i), then second(i), in one launch: two per-particle passes fused,
// where each writes only particle i's entries and reads only what the other
// writes for i (a step's second stage and the next step's first), so the
// fused pass computes what the two launches would, bit for bit.
template <class A, class B>
struct Then {
  A first;
  B second;
  GRANULAR_HD void operator()(unsigned i) const {
    first(i);
    second(i);
  }
};
template <class A, class B>
Then<A, B> then(const A& a, const B& b) {
  return {a, b};
}

// An array in the memory the kernels run on. Move-only.
template <class T>
class DeviceArray {
 public:
  DeviceArray() = default;
  explicit DeviceArray(std::size_t n) { resize(n); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  DeviceArray(DeviceArray&& o) noexcept { swap(o); }
  DeviceArray& operator=(DeviceArray&& o) noexcept {
    swap(o);
    return *this;
  }
  ~DeviceArray() { release(); }

  std::size_t size() const { return n_; }
  T* data() { return ptr(); }
  const T* data() const { return ptr(); }

  // n elements; the contents are not kept.
  void resize(std::size_t n) {
    if (n == n_) return;
    release();
#if defined(__CUDACC__)
    if (n > 0) check(cudaMalloc(reinterpret_cast<void**>(&p_), n * sizeof(T)), "cudaMalloc");
#else
    v_.resize(n);
#endif
    n_ = n;
  }
  // Resized to n and filled from host memory src[0, n).
  void upload(const T* src, std::size_t n) {
    resize(n);
#if defined(__CUDACC__)
    if (n > 0) check(cudaMemcpy(p_, src, n * sizeof(T), cudaMemcpyHostToDevice), "cudaMemcpy to the device");
#else
    std::copy(src, src + n, v_.begin());
#endif
  }
  void upload(const std::vector<T>& src) { upload(src.data(), src.size()); }
  // The contents into host memory dst[0, size()).
  void download(T* dst) const {
#if defined(__CUDACC__)
    if (n_ > 0) check(cudaMemcpy(dst, p_, n_ * sizeof(T), cudaMemcpyDeviceToHost), "cudaMemcpy to the host");
#else
    std::copy(v_.begin(), v_.end(), dst);
#endif
  }
  std::vector<T> download() const {
    std::vector<T> out(n_);
    download(out.data());
    return out;
  }

 private:
#if defined(__CUDACC__)
  T* ptr() const { return p_; }
  void release() {
    if (p_) cudaFree(p_);
    p_ = nullptr;
    n_ = 0;
  }
  void swap(DeviceArray& o) noexcept {
    std::swap(p_, o.p_);
    std::swap(n_, o.n_);
  }
  T* p_ = nullptr;
#else
  T* ptr() const { return const_cast<T*>(v_.data()); }
  void release() {
    v_ = std::vector<T>();
    n_ = 0;
  }
  void swap(DeviceArray& o) noexcept {
    v_.swap(o.v_);
    std::swap(n_, o.n_);
  }
  std::vector<T> v_;
#endif
  std::size_t n_ = 0;
};

// Scratch memory the library calls need (cub's temporary storage).
using Scratch = DeviceArray<unsigned char>;

// The pairs (keys_in[k], values_in[k]), k < n, sorted by key into keys_out,
// values_out; pairs with equal keys keep their order (both builds are stable,
// so they give the same result). Keys below 2^end_bit.
inline void sort_pairs(const std::uint32_t* keys_in, std::uint32_t* keys_out, const std::uint32_t* values_in,
                       std::uint32_t* values_out, unsigned n, int end_bit, Scratch& scratch) {
#if defined(__CUDACC__)
  std::size_t bytes = 0;
  check(cub::DeviceRadixSort::SortPairs(nullptr, bytes, keys_in, keys_out, values_in, values_out, n, 0, end_bit),
        "cub::DeviceRadixSort::SortPairs");
  if (scratch.size() < bytes) scratch.resize(bytes);
  check(cub::DeviceRadixSort::SortPairs(scratch.data(), bytes, keys_in, keys_out, values_in, values_out, n, 0,
                                        end_bit),
        "cub::DeviceRadixSort::SortPairs");
#else
  (void)end_bit;
  (void)scratch;
  std::vector<std::uint32_t> order(n);
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(),
                   [&](std::uint32_t a, std::uint32_t b) { return keys_in[a] < keys_in[b]; });
  for (unsigned k = 0; k < n; ++k) {
    keys_out[k] = keys_in[order[k]];
    values_out[k] = values_in[order[k]];
  }
#endif
}

// The largest of in[0, n) (lowest for n = 0), to the host. out: one element
// of scratch on the device.
template <class T>
T max_of(const T* in, unsigned n, T lowest, DeviceArray<T>& out, Scratch& scratch) {
  if (n == 0) return lowest;
#if defined(__CUDACC__)
  out.resize(1);
  std::size_t bytes = 0;
  check(cub::DeviceReduce::Max(nullptr, bytes, in, out.data(), n), "cub::DeviceReduce::Max");
  if (scratch.size() < bytes) scratch.resize(bytes);
  check(cub::DeviceReduce::Max(scratch.data(), bytes, in, out.data(), n), "cub::DeviceReduce::Max");
  T m = lowest;
  out.download(&m);
  return m;
#else
  (void)out;
  (void)scratch;
  T m = lowest;
  for (unsigned i = 0; i < n; ++i) m = std::max(m, in[i]);
  return m;
#endif
}

// The largest element of each segment [offsets[k], offsets[k + 1]) of in,
// k < segments, to the host (out_host, resized): offsets_host on the host,
// offsets_dev the same on the device; out: `segments` elements of scratch on
// the device. Every segment holds at least one element.
template <class T>
void segment_max(const T* in, const std::vector<std::uint32_t>& offsets_host, const std::uint32_t* offsets_dev,
                 unsigned segments, std::vector<T>& out_host, DeviceArray<T>& out, Scratch& scratch) {
  out_host.resize(segments);
#if defined(__CUDACC__)
  (void)offsets_host;
  out.resize(segments);
  std::size_t bytes = 0;
  check(cub::DeviceSegmentedReduce::Max(nullptr, bytes, in, out.data(), segments, offsets_dev, offsets_dev + 1),
        "cub::DeviceSegmentedReduce::Max");
  if (scratch.size() < bytes) scratch.resize(bytes);
  check(cub::DeviceSegmentedReduce::Max(scratch.data(), bytes, in, out.data(), segments, offsets_dev,
                                        offsets_dev + 1),
        "cub::DeviceSegmentedReduce::Max");
  out.download(out_host.data());
#else
  (void)offsets_dev;
  (void)out;
  (void)scratch;
  for (unsigned k = 0; k < segments; ++k) {
    T m = in[offsets_host[k]];
    for (std::uint32_t i = offsets_host[k] + 1; i < offsets_host[k + 1]; ++i) m = std::max(m, in[i]);
    out_host[k] = m;
  }
#endif
}

// Waits for the kernels launched so far (nothing to wait for on the host).
inline void synchronize() {
#if defined(__CUDACC__)
  check(cudaDeviceSynchronize(), "cudaDeviceSynchronize");
#endif
}

}  // namespace GRANULAR_EXEC_NS
}  // namespace granular::gpu
