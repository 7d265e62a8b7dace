// The output of every scheme and the input of the validator.
#pragma once

#include "sagitta/patch.hpp"

#include <array>
#include <cstdint>
#include <vector>

namespace sagitta {

// Where a vertex lies on the exact surface. A vertex shared by several patches records one of them.
struct SurfacePoint {
  uint32_t patch = 0;
  double u = 0.0;
  double v = 0.0;
};

using Triangle = std::array<uint32_t, 3>;

// Triangle strips stored one after another (compressed rows): strip s is
// indices[offsets[s] .. offsets[s + 1]). One allocation for all strips, where a vector per strip
// cost the ESC scheme a fifth of its time in malloc and free.
class StripList {
 public:
  // One strip's vertex ids (a view into the list; valid until the list changes).
  struct Strip {
    const uint32_t* first;
    const uint32_t* last;
    const uint32_t* begin() const { return first; }
    const uint32_t* end() const { return last; }
    size_t size() const { return static_cast<size_t>(last - first); }
    uint32_t operator[](size_t i) const { return first[i]; }
  };
  class Iterator {
   public:
    Iterator(const StripList* list, size_t s) : list_(list), s_(s) {}
    Strip operator*() const { return (*list_)[s_]; }
    Iterator& operator++() {
      ++s_;
      return *this;
    }
    bool operator!=(const Iterator& o) const { return s_ != o.s_; }

   private:
    const StripList* list_;
    size_t s_;
  };

  size_t size() const { return offsets_.size() - 1; }
  bool empty() const { return size() == 0; }
  void clear() {
    indices_.clear();
    offsets_.assign(1, 0);
  }
  Strip operator[](size_t s) const { return {indices_.data() + offsets_[s], indices_.data() + offsets_[s + 1]}; }
  Iterator begin() const { return {this, 0}; }
  Iterator end() const { return {this, size()}; }
  // Appends one strip.
  template <class It>
  void push_back(It first, It last) {
    indices_.insert(indices_.end(), first, last);
    offsets_.push_back(indices_.size());
  }
  void push_back(const std::vector<uint32_t>& strip) { push_back(strip.begin(), strip.end()); }
  // Appends one strip of n ids, written through the pointer returned (valid until the list changes).
  uint32_t* append(size_t n) {
    indices_.resize(indices_.size() + n);
    offsets_.push_back(indices_.size());
    return indices_.data() + (indices_.size() - n);
  }
  // All vertex ids and the strip offsets (offsets()[0] == 0, one more than size()).
  const std::vector<uint32_t>& indices() const { return indices_; }
  const std::vector<uint64_t>& offsets() const { return offsets_; }
  // Sized for `strips` strips of `ids` vertex ids in all, filled in place (any order) through
  // mutable_indices() and mutable_offsets(): offsets()[s + 1] is where strip s ends.
  void resize(size_t strips, size_t ids) {
    indices_.resize(ids);
    offsets_.assign(strips + 1, 0);
  }
  // Keeps the first `strips` strips and `ids` ids (after filling in place; offsets()[strips] == ids).
  void shrink(size_t strips, size_t ids) {
    indices_.resize(ids);
    offsets_.resize(strips + 1);
  }
  uint32_t* mutable_indices() { return indices_.data(); }
  uint64_t* mutable_offsets() { return offsets_.data(); }
  void reserve(size_t strips, size_t ids) {
    indices_.reserve(ids);
    offsets_.reserve(strips + 1);
  }
  bool operator==(const StripList& o) const { return indices_ == o.indices_ && offsets_ == o.offsets_; }
  bool operator!=(const StripList& o) const { return !(*this == o); }

 private:
  std::vector<uint32_t> indices_;
  std::vector<uint64_t> offsets_ = std::vector<uint64_t>(1, 0);
};

struct Tessellation {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;                  // unit normals, one per position (may be empty)
  std::vector<SurfacePoint> surface_points;   // per vertex; empty for meshes with no exact surface
  std::vector<Triangle> triangles;            // counter-clockwise seen from the normal side
  std::vector<uint32_t> triangle_patch;       // per triangle; empty when unknown
  std::vector<std::array<Vec2, 3>> triangle_uv;  // per triangle corner, in triangle_patch's domain
  StripList strips;                              // triangle strips (ESC), same triangles as above
  uint64_t degenerate_triangles = 0;          // collapsed to a point or a segment: counted, not emitted

  bool has_surface() const { return !triangle_patch.empty() && !triangle_uv.empty(); }
};

// Bytes of a tessellation with every array filled (triangle, patch and (u, v) per triangle;
// position, normal and surface point per vertex), for the memory guard (sagitta/budget.hpp).
inline double tessellation_bytes(double triangles, double vertices) {
  return triangles * double(sizeof(Triangle) + sizeof(uint32_t) + sizeof(std::array<Vec2, 3>)) +
         vertices * double(2 * sizeof(Vec3) + sizeof(SurfacePoint));
}

}  // namespace sagitta
