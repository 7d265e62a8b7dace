// Issue 14: whole-part tessellation against OCCT's BRepMesh_IncrementalMesh on the same part, one
// thread, the shape read once outside the timed loop. Ours at uniform level L, BRepMesh at linear
// deflection d x the part's box diagonal (angular 0.5); counters: triangles. Run:
//   build/tests/bench/sagitta_bench --benchmark_filter=Part
#include "occt_shape.hpp"

#include <BRepBndLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Poly_Triangulation.hxx>
#include <TopExp_Explorer.hxx>
#include <TopLoc_Location.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>

#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

namespace {

using namespace sagitta;

const std::vector<std::string> kParts = {"cad/step/pr1ct.stp", "cad/step/bug24595_281390.stp", "cad/bottle.brep",
                                         "cad/step/trj10_b2-oc-214.stp", "cad/step/bug33398.step"};

bool load(benchmark::State& state, TopoDS_Shape& shape) {
  const std::string path = std::string(SAGITTA_SHARED_DATA) + "/" + kParts[static_cast<size_t>(state.range(0))];
  if (!std::filesystem::exists(path)) {
    state.SkipWithError("shared data absent");
    return false;
  }
  shape = occt::read_cad_shape(path);
  state.SetLabel(std::filesystem::path(path).filename().string());
  return true;
}

void BM_PartSagitta(benchmark::State& state) {
  tbb::global_control threads(tbb::global_control::max_allowed_parallelism, 1);
  TopoDS_Shape shape;
  if (!load(state, shape)) return;
  occt::PartOptions options;
  options.scheme.level = static_cast<int>(state.range(1));
  options.solid_facts = false;  // OCCT's validity check and volume are not tessellation
  size_t triangles = 0;
  for (auto _ : state) {
    const occt::PartMesh part = occt::mesh_part_shape(shape, "bench", options);
    triangles = part.mesh.triangles.size();
    benchmark::DoNotOptimize(part.mesh.positions.data());
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}

void BM_PartBRepMesh(benchmark::State& state) {
  TopoDS_Shape shape;
  if (!load(state, shape)) return;
  Bnd_Box box;
  BRepBndLib::Add(shape, box);
  const double deflection = std::sqrt(box.SquareExtent()) * std::pow(10.0, -static_cast<double>(state.range(1)));
  size_t triangles = 0;
  for (auto _ : state) {
    state.PauseTiming();
    BRepTools::Clean(shape);
    state.ResumeTiming();
    BRepMesh_IncrementalMesh mesh(shape, deflection, false, 0.5, false);
    benchmark::DoNotOptimize(&mesh);
    state.PauseTiming();
    triangles = 0;
    for (TopExp_Explorer it(shape, TopAbs_FACE); it.More(); it.Next()) {
      TopLoc_Location location;
      const Handle(Poly_Triangulation) t = BRep_Tool::Triangulation(TopoDS::Face(it.Current()), location);
      if (!t.IsNull()) triangles += static_cast<size_t>(t->NbTriangles());
    }
    state.ResumeTiming();
  }
  state.counters["triangles"] = static_cast<double>(triangles);
}

// (part, level 2..4) and (part, deflection 10^-2..10^-4 of the diagonal).
BENCHMARK(BM_PartSagitta)->ArgsProduct({{0, 1, 2, 3, 4}, {2, 3, 4}})->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PartBRepMesh)->ArgsProduct({{0, 1, 2, 3, 4}, {2, 3, 4}})->Unit(benchmark::kMillisecond);

}  // namespace
