#pragma once

//! \file local_map.h
//! \brief Per-element values and membership for the few hundred mesh elements a fill touches.
//!
//! \details A fill works on a hole and its neighbourhood; marking elements in a vector sized to
//! the whole mesh (n_vertices, n_faces) would make every pass of every hole cost as much as the
//! mesh, which is what limited small fills on large meshes. This is open addressing on the
//! element index (linear probing, power-of-two capacity, grows at half load), so its cost
//! follows the elements actually marked.

#include <cstddef>
#include <cstdint>
#include <vector>

namespace touchmend::geometry {

template <typename Value>
class LocalMap {
 public:
  explicit LocalMap(std::size_t expected = 32) { reserve(expected); }

  //! The value of \p key, inserted (value-initialised) if absent.
  Value& operator[](int key) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    std::size_t slot = locate(key);
    if (keys_[slot] != key) {
      keys_[slot] = key;
      values_[slot] = Value{};
      ++size_;
    }
    return values_[slot];
  }

  //! Inserts \p key with \p value if absent; true if it was inserted.
  bool insert(int key, const Value& value = Value{}) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    const std::size_t slot = locate(key);
    if (keys_[slot] == key) return false;
    keys_[slot] = key;
    values_[slot] = value;
    ++size_;
    return true;
  }

  const Value* find(int key) const {
    const std::size_t slot = locate(key);
    return keys_[slot] == key ? &values_[slot] : nullptr;
  }
  Value* find(int key) {
    const std::size_t slot = locate(key);
    return keys_[slot] == key ? &values_[slot] : nullptr;
  }
  bool contains(int key) const { return find(key) != nullptr; }
  std::size_t size() const { return size_; }

 private:
  static constexpr int kEmpty = -1;  // element indices are never negative

  void reserve(std::size_t expected) {
    std::size_t capacity = 16;
    while (capacity < 2 * expected) capacity *= 2;
    keys_.assign(capacity, kEmpty);
    values_.assign(capacity, Value{});
    mask_ = capacity - 1;
  }

  std::size_t locate(int key) const {
    // Fibonacci hashing spreads consecutive indices (new elements are consecutive).
    std::size_t slot =
        static_cast<std::size_t>((static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull) >> 20) &
        mask_;
    while (keys_[slot] != kEmpty && keys_[slot] != key) slot = (slot + 1) & mask_;
    return slot;
  }

  void grow() {
    std::vector<int> old_keys = std::move(keys_);
    std::vector<Value> old_values = std::move(values_);
    reserve(old_keys.size());  // twice the entries' room: capacity doubles
    size_ = 0;
    for (std::size_t i = 0; i < old_keys.size(); ++i)
      if (old_keys[i] != kEmpty) insert(old_keys[i], old_values[i]);
  }

  std::vector<int> keys_;
  std::vector<Value> values_;
  std::size_t mask_ = 0;
  std::size_t size_ = 0;
};

//! Membership only.
class LocalSet {
 public:
  explicit LocalSet(std::size_t expected = 32) : map_(expected) {}
  bool insert(int key) { return map_.insert(key, 1); }
  bool contains(int key) const { return map_.contains(key); }
  std::size_t size() const { return map_.size(); }

 private:
  LocalMap<std::uint8_t> map_;
};

}  // namespace touchmend::geometry
