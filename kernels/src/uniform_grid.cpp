#include "sagitta/uniform_grid.hpp"

#include "sagitta/evaluate.hpp"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <array>
#include <string>

namespace sagitta {

namespace {

void check_segments(int segments) {
  if (segments < 1) throw InputError("--segments must be >= 1, got " + std::to_string(segments));
}

// v-basis values of every grid column for one (degree, basis kind), stored basis-major:
// values[j * (N+1) + b] = basis j at v = b / N. The table depends only on the degree and on whether
// the evaluator uses the power basis, so all patches of that kind share it.
struct ColumnTable {
  bool ready = false;
  std::vector<double> values;
};

template <class Out>
void grid_impl(const Model& model, int segments, Out* xyz) {
  check_segments(segments);
  const int n = segments;
  const size_t cols = static_cast<size_t>(n) + 1;
  const size_t per_patch = cols * cols;
  const size_t np = model.patches.size();

  // [power basis?][degree v]
  std::array<std::array<ColumnTable, kMaxDegree + 1>, 2> tables;
  for (const BezierPatch& patch : model.patches) {
    const PatchEvaluator eval(patch);
    ColumnTable& t = tables[eval.uses_power_basis() ? 1 : 0][static_cast<size_t>(patch.degree_v)];
    if (t.ready) continue;
    const int m = patch.degree_v;
    t.values.resize(static_cast<size_t>(m + 1) * cols);
    double b[kMaxDegree + 1], db[kMaxDegree + 1];
    for (int c = 0; c <= n; ++c) {
      eval.basis_row(m, static_cast<double>(c) / n, b, db);
      for (int j = 0; j <= m; ++j) t.values[static_cast<size_t>(j) * cols + static_cast<size_t>(c)] = b[j];
    }
    t.ready = true;
  }

  tbb::parallel_for(tbb::blocked_range<size_t>(0, np), [&](const tbb::blocked_range<size_t>& range) {
    // One row of homogeneous sums, structure of arrays so the column loop vectorises.
    std::vector<double> hx(cols), hy(cols), hz(cols), hw(cols);
    double a_row[kMaxDegree + 1], da_row[kMaxDegree + 1];
    std::array<double, 4> row[kMaxDegree + 1], drow[kMaxDegree + 1];
    for (size_t p = range.begin(); p != range.end(); ++p) {
      const BezierPatch& patch = model.patches[p];
      const PatchEvaluator eval(patch);
      const int m = patch.degree_v;
      const double* table = tables[eval.uses_power_basis() ? 1 : 0][static_cast<size_t>(m)].values.data();
      // A polynomial patch in the power basis has homogeneous weight exactly 1 at every point
      // (weight coefficients 1, 0, ..., 0 and basis value 1 for the constant term), so the
      // division that finish() performs is the identity there and is skipped.
      const bool unit_weight = !patch.rational() && eval.uses_power_basis();
      const Vec3 o = eval.origin();
      Out* out = xyz + 3 * p * per_patch;
      double* x = hx.data();
      double* y = hy.data();
      double* z = hz.data();
      double* w = hw.data();
      for (int a = 0; a <= n; ++a) {
        eval.basis_row(patch.degree_u, static_cast<double>(a) / n, a_row, da_row);
        eval.contract_u(a_row, da_row, row, drow);
        for (size_t c = 0; c < cols; ++c) x[c] = y[c] = z[c] = w[c] = 0.0;
        for (int j = 0; j <= m; ++j) {
          const double* bj = table + static_cast<size_t>(j) * cols;
          const double rx = row[j][0], ry = row[j][1], rz = row[j][2], rw = row[j][3];
          for (size_t c = 0; c < cols; ++c) {
            x[c] += bj[c] * rx;
            y[c] += bj[c] * ry;
            z[c] += bj[c] * rz;
          }
          if (!unit_weight) {
            for (size_t c = 0; c < cols; ++c) w[c] += bj[c] * rw;
          }
        }
        if (unit_weight) {
          for (size_t c = 0; c < cols; ++c) {
            out[3 * c + 0] = static_cast<Out>(o.x + x[c]);
            out[3 * c + 1] = static_cast<Out>(o.y + y[c]);
            out[3 * c + 2] = static_cast<Out>(o.z + z[c]);
          }
        } else {
          for (size_t c = 0; c < cols; ++c) {
            out[3 * c + 0] = static_cast<Out>(o.x + x[c] / w[c]);
            out[3 * c + 1] = static_cast<Out>(o.y + y[c] / w[c]);
            out[3 * c + 2] = static_cast<Out>(o.z + z[c] / w[c]);
          }
        }
        out += 3 * cols;
      }
    }
  });
}

}  // namespace

uint64_t uniform_grid_patch_vertices(int segments) {
  check_segments(segments);
  const uint64_t c = static_cast<uint64_t>(segments) + 1;
  return c * c;
}

uint64_t uniform_grid_vertices(const Model& model, int segments) {
  return uniform_grid_patch_vertices(segments) * model.patches.size();
}

std::vector<Triangle> uniform_grid_pattern(int segments) {
  check_segments(segments);
  const uint32_t c = static_cast<uint32_t>(segments) + 1;
  std::vector<Triangle> t;
  t.reserve(2 * static_cast<size_t>(segments) * static_cast<size_t>(segments));
  for (uint32_t a = 0; a + 1 < c; ++a) {
    for (uint32_t b = 0; b + 1 < c; ++b) {
      const uint32_t v00 = a * c + b, v10 = (a + 1) * c + b, v01 = a * c + b + 1, v11 = (a + 1) * c + b + 1;
      t.push_back({v00, v10, v11});
      t.push_back({v00, v11, v01});
    }
  }
  return t;
}

void tessellate_uniform_grid(const Model& model, int segments, float* xyz) { grid_impl(model, segments, xyz); }
void tessellate_uniform_grid(const Model& model, int segments, double* xyz) { grid_impl(model, segments, xyz); }

}  // namespace sagitta
