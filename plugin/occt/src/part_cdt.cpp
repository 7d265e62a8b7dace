#include "part_cdt.hpp"

#include <CGAL/Constrained_Delaunay_triangulation_2.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Triangulation_data_structure_2.h>
#include <CGAL/Triangulation_vertex_base_with_info_2.h>

#include <cmath>
#include <map>
#include <set>
#include <stdexcept>

namespace sagitta::occt::detail {

namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
struct Info {
  int64_t index = -1;  // into CdtResult::points; -1 until numbered
};
using Vb = CGAL::Triangulation_vertex_base_with_info_2<Info, Kernel>;
using Fb = CGAL::Constrained_triangulation_face_base_2<Kernel>;
using Tds = CGAL::Triangulation_data_structure_2<Vb, Fb>;
using Cdt = CGAL::Constrained_Delaunay_triangulation_2<Kernel, Tds, CGAL::Exact_predicates_tag>;

}  // namespace

CdtResult constrained_delaunay(const std::vector<Vec2>& points, const std::vector<std::array<uint32_t, 2>>& constraints,
                               size_t loop_constraints) {
  // CGAL's triangulation assumes finite coordinates and valid vertex handles: a NaN or an index
  // past the points would corrupt it (a crash, not an exception).
  for (const Vec2& p : points) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y))
      throw std::runtime_error("internal: a point of the face's (u, v) triangulation is not finite");
  }
  for (const auto& c : constraints) {
    if (c[0] >= points.size() || c[1] >= points.size())
      throw std::runtime_error("internal: a constraint of the face's (u, v) triangulation names no point");
  }
  CdtResult r;
  r.points = points;
  r.merged.resize(points.size());
  Cdt cdt;
  std::vector<Cdt::Vertex_handle> handles(points.size());
  Cdt::Face_handle hint;
  for (size_t k = 0; k < points.size(); ++k) {
    handles[k] = cdt.insert(Cdt::Point(points[k].x, points[k].y), hint);
    hint = handles[k]->face();
    if (handles[k]->info().index < 0) handles[k]->info().index = static_cast<int64_t>(k);
    r.merged[k] = static_cast<uint32_t>(handles[k]->info().index);
  }
  for (const auto& c : constraints) {
    if (handles[c[0]] != handles[c[1]]) cdt.insert_constraint(handles[c[0]], handles[c[1]]);
  }
  // Points all on one line (a loop of two distinct points, say) make a triangulation of dimension
  // below 2: it has no faces, and its edges are not faces with three neighbours to flood-fill.
  if (cdt.dimension() < 2) return r;
  for (auto v = cdt.finite_vertices_begin(); v != cdt.finite_vertices_end(); ++v) {
    if (v->info().index < 0) {
      v->info().index = static_cast<int64_t>(r.points.size());
      r.points.push_back(Vec2(v->point().x(), v->point().y()));
    }
  }
  // Edges forced by the non-loop constraints do not bound the inside.
  std::set<std::pair<Cdt::Vertex_handle, Cdt::Vertex_handle>> forced;
  for (size_t k = loop_constraints; k < constraints.size(); ++k) {
    const Cdt::Vertex_handle a = handles[constraints[k][0]], b = handles[constraints[k][1]];
    forced.insert({std::min(a, b), std::max(a, b)});
  }
  const auto toggles = [&](Cdt::Face_handle f, int i) {
    if (!cdt.is_constrained(Cdt::Edge(f, i))) return false;
    const Cdt::Vertex_handle a = f->vertex(Cdt::cw(i)), b = f->vertex(Cdt::ccw(i));
    return forced.count({std::min(a, b), std::max(a, b)}) == 0;
  };
  // Flood fill by nesting level from the unbounded face (CGAL's polygon-with-holes example).
  std::map<Cdt::Face_handle, int> level;
  std::vector<Cdt::Face_handle> current{cdt.infinite_face()}, next;
  for (int depth = 0; !current.empty(); ++depth) {
    while (!current.empty()) {
      const Cdt::Face_handle f = current.back();
      current.pop_back();
      if (level.count(f)) continue;
      level[f] = depth;
      for (int i = 0; i < 3; ++i) {
        const Cdt::Face_handle n = f->neighbor(i);
        if (level.count(n)) continue;
        (toggles(f, i) ? next : current).push_back(n);
      }
    }
    current.swap(next);
  }
  for (auto f = cdt.finite_faces_begin(); f != cdt.finite_faces_end(); ++f) {
    r.triangles.push_back({static_cast<uint32_t>(f->vertex(0)->info().index),
                           static_cast<uint32_t>(f->vertex(1)->info().index),
                           static_cast<uint32_t>(f->vertex(2)->info().index)});
    const auto it = level.find(f);
    r.inside.push_back(it != level.end() && it->second % 2 == 1);
  }
  return r;
}

}  // namespace sagitta::occt::detail
