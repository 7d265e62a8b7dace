// The OCCT peer: BRepMesh_IncrementalMesh on our patches or on a CAD shape, then our validator.
#include "sagitta/occt/cad.hpp"

#include "occt_shape.hpp"

#include "sagitta/evaluate.hpp"

#include <glm/geometric.hpp>

#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_Sewing.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRep_Tool.hxx>
#include <Geom_BezierSurface.hxx>
#include <Poly_Triangulation.hxx>
#include <Precision.hxx>
#include <Standard_Failure.hxx>
#include <TColStd_Array2OfReal.hxx>
#include <TColgp_Array2OfPnt.hxx>
#include <TopExp.hxx>
#include <TopLoc_Location.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>

namespace sagitta::occt {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Collects face triangulations into one Tessellation, merging vertices with bit-identical positions
// (BRepMesh gives the nodes of a shared edge the same 3D points on both faces).
class MeshCollector {
 public:
  // Appends the face's triangles. patch >= 0: the face is exactly that Bézier patch over [0, 1]^2,
  // so each node's UV is its (u, v) and triangles carry triangle_patch / triangle_uv.
  // Returns the number of triangles, or -1 when the face has no triangulation.
  long add_face(const TopoDS_Face& face, int patch, const Model* model, double& max_node_offset) {
    TopLoc_Location loc;
    const Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, loc);
    if (tri.IsNull()) return -1;
    const gp_Trsf trsf = loc.Transformation();
    if (patch >= 0 && !tri->HasUVNodes()) throw InputError("OCCT's triangulation of patch " + std::to_string(patch) + " has no (u, v) nodes");
    const bool uv = patch >= 0;
    std::vector<uint32_t> id(static_cast<size_t>(tri->NbNodes()) + 1);
    std::vector<Vec2> node_uv(id.size());
    for (int n = 1; n <= tri->NbNodes(); ++n) {
      const gp_Pnt q = tri->Node(n).Transformed(trsf);
      const Vec3 x{q.X(), q.Y(), q.Z()};
      if (uv) {
        const gp_Pnt2d t = tri->UVNode(n);
        node_uv[n] = {t.X(), t.Y()};
        const auto s = de_casteljau<long double>(model->patches[patch], t.X(), t.Y());
        const Vec3 exact{static_cast<double>(s[0]), static_cast<double>(s[1]), static_cast<double>(s[2])};
        max_node_offset = std::max(max_node_offset, glm::length(exact - x));
      }
      const Key key = key_of(x);
      auto it = index_.find(key);
      if (it == index_.end()) {
        it = index_.emplace(key, static_cast<uint32_t>(mesh.positions.size())).first;
        mesh.positions.push_back(x);
        if (uv) mesh.surface_points.push_back({static_cast<uint32_t>(patch), node_uv[n].x, node_uv[n].y});
      }
      id[n] = it->second;
    }
    const bool reversed = face.Orientation() == TopAbs_REVERSED;
    for (int t = 1; t <= tri->NbTriangles(); ++t) {
      int a, b, c;
      tri->Triangle(t).Get(a, b, c);
      if (reversed) std::swap(b, c);
      mesh.triangles.push_back({id[a], id[b], id[c]});
      if (uv) {
        mesh.triangle_patch.push_back(static_cast<uint32_t>(patch));
        mesh.triangle_uv.push_back({node_uv[a], node_uv[b], node_uv[c]});
      }
    }
    return tri->NbTriangles();
  }

  Tessellation mesh;

 private:
  using Key = std::array<uint64_t, 3>;
  static Key key_of(const Vec3& x) {
    Key k;
    std::memcpy(&k[0], &x.x, 8);
    std::memcpy(&k[1], &x.y, 8);
    std::memcpy(&k[2], &x.z, 8);
    return k;
  }
  std::map<Key, uint32_t> index_;
};

void run_mesher(const TopoDS_Shape& shape, const PeerOptions& o, PeerResult& r) {
  if (!(o.deflection > 0.0) || !std::isfinite(o.deflection)) throw InputError("--deflection must be a positive number");
  if (!(o.angle > 0.0) || !std::isfinite(o.angle)) throw InputError("--angle must be a positive number (radians)");
  const auto start = std::chrono::steady_clock::now();
  BRepMesh_IncrementalMesh mesher(shape, o.deflection, o.relative, o.angle, Standard_True);
  r.mesh_seconds = seconds_since(start);
}

void validate(const Model& model, PeerResult& r, const PeerOptions& o) {
  const auto start = std::chrono::steady_clock::now();
  if (r.mesh.triangles.empty()) throw InputError(model.name + ": OCCT produced no triangles on the faces that can be validated");
  r.distance = certify_distance(model, r.mesh, o.certify);
  r.validate_seconds = seconds_since(start);
}

}  // namespace

PeerResult peer_mesh_model(const Model& model, const PeerOptions& options) {
  validate_model(model, model.name.empty() ? "model" : model.name);
  PeerResult r;
  std::vector<TopoDS_Face> faces;
  try {
    for (const BezierPatch& p : model.patches) {
      TColgp_Array2OfPnt poles(1, p.rows(), 1, p.cols());
      TColStd_Array2OfReal weights(1, p.rows(), 1, p.cols());
      for (int i = 0; i < p.rows(); ++i) {
        for (int j = 0; j < p.cols(); ++j) {
          const Vec3& x = p.at(i, j);
          poles(i + 1, j + 1) = gp_Pnt(x.x, x.y, x.z);
          weights(i + 1, j + 1) = p.weight(i, j);
        }
      }
      Handle(Geom_BezierSurface) surface =
          p.rational() ? new Geom_BezierSurface(poles, weights) : new Geom_BezierSurface(poles);
      BRepBuilderAPI_MakeFace make(surface, Precision::Confusion());
      if (!make.IsDone()) throw InputError(model.name + ": OCCT could not make a face of patch " + std::to_string(faces.size()));
      faces.push_back(make.Face());
    }
    // Sewing joins faces whose boundaries coincide within the tolerance; the tea set's gaps (>= 3e-4)
    // stay open, as in our own topology.
    BRepBuilderAPI_Sewing sewing(1e-7 * std::max(1.0, model_box(model).diagonal()));
    for (const TopoDS_Face& f : faces) sewing.Add(f);
    sewing.Perform();
    const TopoDS_Shape sewn = sewing.SewedShape();
    // Sewing drops faces it finds degenerate (a patch collapsed to a point or a line); OCCT has
    // nothing to mesh then.
    if (sewn.IsNull()) throw InputError(model.name + ": OCCT's sewing removed every patch (degenerate geometry)");
    run_mesher(sewn, options, r);
    MeshCollector collector;
    for (size_t p = 0; p < faces.size(); ++p) {
      const TopoDS_Shape& s = sewing.IsModified(faces[p]) ? sewing.Modified(faces[p]) : faces[p];
      if (s.IsNull()) {  // removed by the sewing as degenerate: no mesh from OCCT
        ++r.faces_without_mesh;
        continue;
      }
      if (s.ShapeType() != TopAbs_FACE) throw InputError(model.name + ": sewing did not keep patch " + std::to_string(p) + " a face");
      const long n = collector.add_face(TopoDS::Face(s), static_cast<int>(p), &model, r.max_node_offset);
      if (n < 0) {
        ++r.faces_without_mesh;
        continue;
      }
      ++r.faces_meshed;
      r.triangles += static_cast<size_t>(n);
    }
    r.mesh = std::move(collector.mesh);
  } catch (const Standard_Failure& e) {
    throw InputError(model.name + ": OCCT failed (" + std::string(e.GetMessageString()) + ")");
  }
  r.triangles_validated = r.mesh.triangles.size();
  r.route = "bernstein";
  validate(model, r, options);
  return r;
}

}  // namespace sagitta::occt
