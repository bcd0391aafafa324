#pragma once
// ChannelBuffer: per-call scratch space of one value per measurement channel
// (or per channel and parameter), for any channel count.
//
// The inverters and the estimator need a few such arrays per pixel. Up to
// kInlineValues values live inside the object (on the caller's stack, left
// uninitialised: no cost where the old fixed arrays had none); a larger
// request (a plan of many channels times four Jacobian columns) takes one
// heap allocation. There is no upper limit on the channel count.
//
// Not copyable (the pointer would dangle); not thread-safe (one per call).

#include <cstddef>
#include <memory>

namespace chromo::estimation {

template <class T, std::size_t kInlineValues = 128>
class ChannelBuffer {
 public:
  explicit ChannelBuffer(std::size_t count) {
    if (count > kInlineValues) {
      heap_ = std::make_unique<T[]>(count);
      data_ = heap_.get();
    } else {
      data_ = inline_;
    }
  }
  // As above with every value set to `fill`.
  ChannelBuffer(std::size_t count, T fill) : ChannelBuffer(count) {
    for (std::size_t i = 0; i < count; ++i) data_[i] = fill;
  }
  ChannelBuffer(const ChannelBuffer&) = delete;
  ChannelBuffer& operator=(const ChannelBuffer&) = delete;

  T* data() { return data_; }
  const T* data() const { return data_; }
  operator T*() { return data_; }
  operator const T*() const { return data_; }

 private:
  T inline_[kInlineValues];
  std::unique_ptr<T[]> heap_;
  T* data_ = nullptr;
};

}  // namespace chromo::estimation
