// `sagitta report` internals (plugin/cli/report.hpp) on the pillow box: every point's certified
// interval contains a brute-force sampled distance, the Pareto front matches an exhaustive
// dominance check, each scheme gets a fit and a verdict, and the HTML embeds the plots (or says in
// one line why they are missing).
#include "report.hpp"

#include "sagitta/evaluate.hpp"
#include "sagitta/fixtures.hpp"
#include "sagitta/uniform.hpp"
#include "brute_force.hpp"

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <unistd.h>

namespace sagitta::cli {
namespace {

// Largest distance from surface samples (long-double de Casteljau) to the mesh, by brute force over
// all triangles: a lower bound of the Hausdorff distance (up to rounding).
double sampled_surface_to_mesh(const Model& model, const Tessellation& mesh, int samples) {
  double worst = 0.0;
  for (const BezierPatch& patch : model.patches) {
    for (int i = 0; i <= samples; ++i) {
      for (int j = 0; j <= samples; ++j) {
        const auto s = de_casteljau<long double>(patch, static_cast<long double>(i) / samples, static_cast<long double>(j) / samples);
        const Vec3 x{static_cast<double>(s[0]), static_cast<double>(s[1]), static_cast<double>(s[2])};
        double nearest = 1e300;
        for (const Triangle& t : mesh.triangles) {
          nearest = std::min(nearest, test::point_triangle_distance(x, mesh.positions[t[0]], mesh.positions[t[1]], mesh.positions[t[2]]));
        }
        worst = std::max(worst, nearest);
      }
    }
  }
  return worst;
}

void expect_consistent_intervals(const nlohmann::json& report) {
  const nlohmann::json& m = report["models"][0];
  ASSERT_EQ(m["name"], "pillow");
  std::set<std::string> schemes;
  for (const auto& p : m["points"]) {
    schemes.insert(p["scheme"].get<std::string>());
    ASSERT_FALSE(p["certified_error"].is_null()) << p["setting"];
    EXPECT_LE(p["lower_bound"].get<double>(), p["certified_error"].get<double>() * (1 + 1e-12)) << p["setting"];
    EXPECT_GT(p["triangles"].get<uint64_t>(), 0u);
    EXPECT_GE(p["seconds"].get<double>(), 0.0);
  }
  EXPECT_EQ(schemes, (std::set<std::string>{"uniform", "esc", "pn", "occt"}));
}

void expect_uniform_points_match(const Model& model, const nlohmann::json& report) {
  const Topology topology = build_topology(model);
  for (const auto& p : report["models"][0]["points"]) {
    if (p["scheme"] != "uniform") continue;
    const int level = p["params"]["level"].get<int>();
    EXPECT_EQ(p["triangles"].get<uint64_t>(), uniform_triangle_count(model, segments_for_level(level)));  // no collapsed sides
    if (level > 2) continue;
    UniformParams params;
    params.segments = segments_for_level(level);
    const double sampled = sampled_surface_to_mesh(model, tessellate_uniform(model, topology, params), 24);
    EXPECT_LE(sampled, p["certified_error"].get<double>() * (1 + 1e-9)) << "level " << level;
    EXPECT_GE(sampled, 0.5 * p["certified_error"].get<double>()) << "level " << level;  // the bound is not loose
  }
}

void expect_exhaustive_pareto_front(const nlohmann::json& report) {
  const nlohmann::json& m = report["models"][0];
  const auto& points = m["points"];
  std::set<size_t> expected;
  for (size_t i = 0; i < points.size(); ++i) {
    bool dominated = false;
    for (size_t j = 0; j < points.size(); ++j) {
      const double ti = points[i]["triangles"].get<double>(), tj = points[j]["triangles"].get<double>();
      const double ei = points[i]["certified_error"].get<double>(), ej = points[j]["certified_error"].get<double>();
      if (j != i && ((tj <= ti && ej < ei) || (tj < ti && ej <= ei))) dominated = true;
    }
    if (!dominated) expected.insert(i);
  }
  std::set<size_t> front;
  for (const auto& i : m["pareto_triangles"]) front.insert(i.get<size_t>());
  EXPECT_EQ(front, expected);
  EXPECT_FALSE(front.empty());
}

void expect_fits_and_verdicts(const nlohmann::json& report) {
  const nlohmann::json& schemes = report["models"][0]["schemes"];
  int best = 0;
  for (const auto& [name, s] : schemes.items()) {
    EXPECT_FALSE(s["verdict"].get<std::string>().empty()) << name;
    ASSERT_TRUE(s.contains("fit")) << name;
    for (double r : s["fit"]["log_residuals"]) EXPECT_TRUE(std::isfinite(r));
    best += s["rank"] == "best" ? 1 : 0;
  }
  EXPECT_EQ(best, 1);
  // A second-order scheme: error ~ h^2 ~ 1 / triangles.
  EXPECT_NEAR(schemes["uniform"]["fit"]["p"].get<double>(), -1.0, 0.2);
}

std::string read_text(const std::filesystem::path& path) {
  std::ifstream in(path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

bool have_matplotlib() { return std::system("/usr/bin/python3 -c 'import matplotlib' >/dev/null 2>&1") == 0; }

void expect_html_with_plots(const nlohmann::json& report) {
  const auto dir = std::filesystem::temp_directory_path() / ("sagitta_report_test_" + std::to_string(::getpid()));
  const std::string html_path = write_trade_report(report, dir.string());
  const std::string html = read_text(html_path);
  EXPECT_NE(html.find("pillow"), std::string::npos);
  EXPECT_NE(html.find("Verdict per scheme"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(dir / "report.json"));
  if (have_matplotlib()) {
    EXPECT_TRUE(std::filesystem::exists(dir / "model_0_triangles.png"));
    EXPECT_TRUE(std::filesystem::exists(dir / "model_0_time.png"));
    size_t images = 0;
    for (size_t at = html.find("data:image/png;base64,"); at != std::string::npos; at = html.find("data:image/png;base64,", at + 1)) ++images;
    EXPECT_EQ(images, 2u);
  } else {
    EXPECT_NE(html.find("class=\"notice\""), std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

// One report (about 5 s in Release; every check reads it).
TEST(Report, PillowBoxReportIsConsistentCertifiedAndReadable) {
  const Model model = fixtures::pillow_box();
  ReportOptions options;
  options.occt = true;
  const nlohmann::json report = build_trade_report({{"pillow", model}}, options);
  expect_consistent_intervals(report);
  expect_uniform_points_match(model, report);
  expect_exhaustive_pareto_front(report);
  expect_fits_and_verdicts(report);
  expect_html_with_plots(report);
}

TEST(Report, MissingPlotScriptGivesANoticeNotAFailure) {
  // A minimal hand-written report: one model, one point.
  const nlohmann::json report = nlohmann::json::parse(R"({
    "error": "e", "time": "t",
    "models": [{"name": "m", "patches": 1, "box_diagonal": 1.0, "reference_error": 0.01,
                "points": [{"scheme": "uniform", "setting": "level 1", "triangles": 8, "seconds": 0.001,
                            "certified_error": 0.1, "lower_bound": 0.09, "certify_seconds": 0.01}],
                "pareto_triangles": [0], "pareto_time": [0], "skipped": [],
                "schemes": {"uniform": {"verdict": "only one point", "rank": "unknown"}}}]})");
  const auto dir = std::filesystem::temp_directory_path() / ("sagitta_report_noplot_" + std::to_string(::getpid()));
  ::setenv("SAGITTA_REPORT_SCRIPT", "/nonexistent/plot_report.py", 1);
  const std::string html = read_text(write_trade_report(report, dir.string()));
  ::unsetenv("SAGITTA_REPORT_SCRIPT");
  EXPECT_NE(html.find("class=\"notice\""), std::string::npos);
  EXPECT_EQ(html.find("data:image/png"), std::string::npos);
  EXPECT_NE(html.find("only one point"), std::string::npos);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace sagitta::cli
