#pragma once

//! \file triple_buffer.h
//! \brief A wait-free single-producer/single-consumer "latest value" mailbox.
//!
//! \details Three slots: the producer fills its back slot and publishes it by swapping it with
//! the middle slot; the consumer takes the middle slot by swapping it with its front slot when
//! a fresh value is there. Neither side ever waits for the other, nor allocates, and a value
//! is never read while it is being written (no torn reads, unlike a seqlock on plain data).
//! Used for device states (driver thread → haptic thread), force commands (haptic → driver)
//! and proxy patches (proxy-update thread → haptic thread).

#include <array>
#include <atomic>
#include <cstdint>

namespace touchmend::device {

template <class T>
class TripleBuffer {
 public:
  TripleBuffer() = default;
  explicit TripleBuffer(const T& initial) { slots_.fill(initial); }

  // ---- producer ----
  //! The slot to fill before publish(); stays the producer's until then.
  T& back() { return slots_[back_]; }
  void publish() {
    const std::uint8_t old =
        middle_.exchange(static_cast<std::uint8_t>(back_ | kFresh), std::memory_order_acq_rel);
    back_ = old & kIndex;
  }
  void publish(const T& value) {
    back() = value;
    publish();
  }

  // ---- consumer ----
  //! Takes the newest published value if there is one; true if it changed.
  bool update() {
    if ((middle_.load(std::memory_order_acquire) & kFresh) == 0) return false;
    const std::uint8_t old = middle_.exchange(front_, std::memory_order_acq_rel);
    front_ = old & kIndex;
    return true;
  }
  //! The consumer's current value (the newest one as of the last update()).
  const T& front() const { return slots_[front_]; }
  T& front_mutable() { return slots_[front_]; }

 private:
  static constexpr std::uint8_t kIndex = 0x3;
  static constexpr std::uint8_t kFresh = 0x4;
  std::array<T, 3> slots_{};
  std::uint8_t back_ = 0;
  std::atomic<std::uint8_t> middle_{1};
  std::uint8_t front_ = 2;
};

}  // namespace touchmend::device
