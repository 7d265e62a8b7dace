// The run's budget (sagitta/budget.hpp, issue 20 items 5-7): cancellation from another thread and
// a deadline stop the validator and the tessellators; the memory limit refuses replication,
// topology and meshes before they are allocated; near misses are reported only within their stated
// tolerance, found without a quadratic pass.
#include "sagitta/budget.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/io/model_io.hpp"
#include "sagitta/model.hpp"
#include "sagitta/uniform.hpp"
#include "test_support.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

namespace sagitta {
namespace {

// Every test starts and ends with no budget (the budget is process-wide).
class Budget : public ::testing::Test {
 protected:
  void SetUp() override { budget::reset(); }
  void TearDown() override { budget::reset(); }
};

Tessellation uniform_mesh(const Model& model, int segments) {
  UniformParams params;
  params.segments = segments;
  return tessellate_uniform(model, build_topology(model), params);
}

TEST_F(Budget, CancelFromAnotherThreadStopsTheValidator) {
  const Model model = fixtures::default_model();
  const Tessellation mesh = uniform_mesh(model, 64);  // about 5 s of certification on a 2-core machine
  std::thread canceller([] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    budget::request_cancel();
  });
  try {
    certify_distance(model, mesh);
    canceller.join();
    FAIL() << "the validator finished despite the cancellation";
  } catch (const BudgetExhausted& e) {
    canceller.join();
    EXPECT_NE(std::string(e.what()).find("interrupted during validation"), std::string::npos) << e.what();
  }
}

TEST_F(Budget, CancelledBeforeStartStopsEveryStage) {
  const Model model = fixtures::default_model();
  const Tessellation mesh = uniform_mesh(model, 2);
  std::thread([] { budget::request_cancel(); }).join();
  EXPECT_THROW(certify_distance(model, mesh), BudgetExhausted);
  EXPECT_THROW(uniform_mesh(model, 4), BudgetExhausted);
  EXPECT_THROW(build_topology(replicate(model, 10)), BudgetExhausted);
}

TEST_F(Budget, DeadlineStopsTheTessellationWithItsReason) {
  budget::set_max_seconds(1e-6);
  std::this_thread::sleep_for(std::chrono::milliseconds(2));
  try {
    uniform_mesh(fixtures::default_model(), 8);
    FAIL() << "the tessellation ignored the deadline";
  } catch (const BudgetExhausted& e) {
    EXPECT_NE(std::string(e.what()).find("time budget exhausted (--max-seconds 1e-06)"), std::string::npos) << e.what();
  }
  budget::set_max_seconds(0.0);  // no limit again
  EXPECT_NO_THROW(uniform_mesh(fixtures::default_model(), 2));
}

TEST_F(Budget, MemoryLimitRefusesBeforeAllocating) {
  const Model box = fixtures::pillow_box();
  budget::set_max_bytes(64.0 * (1 << 20));
  // A million copies of the box: about 6 million patches, refused before one is copied.
  try {
    replicate(box, 1000000);
    FAIL() << "replicate ignored the memory limit";
  } catch (const MemoryLimitExceeded& e) {
    EXPECT_NE(std::string(e.what()).find("1000000 copies of the model would need about"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("more than --max-memory 0.0625 GiB"), std::string::npos) << e.what();
  }
  // Under the limit the copies are made; their topology and a fine mesh are refused where allocated.
  const Model copies = replicate(box, 5000);
  EXPECT_THROW(build_topology(copies), MemoryLimitExceeded);
  EXPECT_THROW(uniform_mesh(box, 1024), MemoryLimitExceeded);
  EXPECT_NO_THROW(uniform_mesh(box, 8));
}

// n x n x n bilinear squares `size` wide on a lattice `spacing` apart: disjoint, each side facing
// its neighbour's across a gap of spacing - size.
Model lattice(int n, double size, double spacing) {
  Model model;
  for (int a = 0; a < n; ++a) {
    for (int b = 0; b < n; ++b) {
      for (int c = 0; c < n; ++c) {
        const Vec3 o(a * spacing, b * spacing, c * spacing);
        BezierPatch p;
        p.degree_u = p.degree_v = 1;
        p.points = {o, o + Vec3(0, size, 0), o + Vec3(size, 0, 0), o + Vec3(size, size, 0)};
        model.patches.push_back(p);
      }
    }
  }
  return model;
}

TEST(NearMisses, DisjointPatchesAreNotNearMisses) {
  // 1,000 squares 0.01 wide with gaps of 0.0015 (15 % of their size): with the old tolerance (1 %
  // of the box diagonal, 0.002) every facing pair was a "near miss" (1,800 of them).
  const Model model = lattice(10, 0.01, 0.0115);
  const Topology topo = build_topology(model);
  EXPECT_EQ(topo.free_edges(), 4000u);
  EXPECT_EQ(topo.near_misses.size(), 0u);
  EXPECT_EQ(topo.near_collapsed.size(), 0u);
  // The tolerance is stated: model-wide 1 % of the diagonal, capped at 5 % of each patch's size.
  EXPECT_EQ(topo.near_miss_tolerance, kNearMissModelFraction * model_box(model).diagonal());
  EXPECT_EQ(topo.near_miss_patch_fraction, kNearMissPatchFraction);
}

TEST(NearMisses, RealSeamGapsAreStillFound) {
  // The same lattice with gaps of 0.0001 (1 % of the patch size): each facing pair is a seam gap,
  // 2 directions x 9 x 10 x 10 pairs (the squares lie in z planes, whose sides do not face).
  const Topology topo = build_topology(lattice(10, 0.01, 0.0101));
  EXPECT_EQ(topo.near_misses.size(), 1800u);
  for (const Topology::NearMiss& m : topo.near_misses) EXPECT_NEAR(m.distance, 1e-4, 1e-12);
  // An explicit tolerance applies as given (model units).
  EXPECT_EQ(build_topology(lattice(10, 0.01, 0.0101), 5e-5).near_misses.size(), 0u);
}

TEST(NearMisses, CopiesSpreadFarApartKeepTheirOwnNearMisses) {
  const std::string path = test::shared_data("teaspoon.bpt");
  SAGITTA_REQUIRE_DATA(path);
  // The teaspoon has 3 near misses and 4 near-collapsed sides (test_topology.cpp); 400 copies on a
  // 20 x 20 grid have 400 times that. The old model-wide tolerance (1 % of the whole grid's
  // diagonal) made most open sides "near collapsed" and paired sides of different copies.
  const Topology topo = build_topology(replicate(io::read_bpt(path), 400));
  EXPECT_EQ(topo.near_misses.size(), 3u * 400u);
  EXPECT_EQ(topo.near_collapsed.size(), 4u * 400u);
  for (const Topology::NearMiss& m : topo.near_misses) EXPECT_EQ(m.a.patch / 16, m.b.patch / 16);  // same copy
}

}  // namespace
}  // namespace sagitta
