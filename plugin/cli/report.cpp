// `sagitta report`: certified error against triangles and time for every scheme (see report.hpp).
#include "report.hpp"

#include "commands.hpp"
#include "progress.hpp"

#include "sagitta/app/part.hpp"
#include "sagitta/certify.hpp"
#include "sagitta/esc.hpp"
#include "sagitta/fit.hpp"
#include "sagitta/io/mesh_io.hpp"
#include "sagitta/occt/cad.hpp"
#include "sagitta/scheme.hpp"
#include "sagitta/uniform.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <sstream>

#ifndef SAGITTA_REPORT_SCRIPT
#define SAGITTA_REPORT_SCRIPT ""
#endif

namespace sagitta::cli {

namespace {

std::string base64(const std::string& bytes) {
  static const char* k = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  size_t i = 0;
  for (; i + 2 < bytes.size(); i += 3) {
    const uint32_t n = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8) | uint8_t(bytes[i + 2]);
    out += {k[n >> 18], k[(n >> 12) & 63], k[(n >> 6) & 63], k[n & 63]};
  }
  if (i + 1 == bytes.size()) {
    const uint32_t n = uint8_t(bytes[i]) << 16;
    out += {k[n >> 18], k[(n >> 12) & 63], '=', '='};
  } else if (i + 2 == bytes.size()) {
    const uint32_t n = (uint8_t(bytes[i]) << 16) | (uint8_t(bytes[i + 1]) << 8);
    out += {k[n >> 18], k[(n >> 12) & 63], k[(n >> 6) & 63], '='};
  }
  return out;
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else if (c == '"') out += "&quot;";
    else out += c;
  }
  return out;
}

std::string shell_quote(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

// plot_report.py: $SAGITTA_REPORT_SCRIPT, then <bin>/../share/sagitta/, then the source tree.
std::string find_plot_script() {
  if (const char* env = std::getenv("SAGITTA_REPORT_SCRIPT"); env && *env) return env;
  std::error_code ec;
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const auto installed = exe.parent_path().parent_path() / "share" / "sagitta" / "plot_report.py";
    if (std::filesystem::exists(installed, ec)) return installed.string();
  }
  if (std::filesystem::exists(SAGITTA_REPORT_SCRIPT, ec)) return SAGITTA_REPORT_SCRIPT;
  return "";
}

// Runs the plot script; returns "" on success or the reason the plots are missing.
std::string make_plots(const std::string& json_path, const std::string& out_dir) {
  const std::string script = find_plot_script();
  if (script.empty()) return "the plotting script plot_report.py was not found";
  const std::string python = std::filesystem::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
  const std::string log = (std::filesystem::path(out_dir) / "plot.log").string();
  const std::string command = python + " " + shell_quote(script) + " " + shell_quote(json_path) + " " + shell_quote(out_dir) +
                              " >" + shell_quote(log) + " 2>&1";
  const int rc = std::system(command.c_str());
  if (rc != 0) {
    std::ifstream in(log);
    std::string line, last;
    while (std::getline(in, line)) {
      if (!line.empty()) last = line;
    }
    return "plots unavailable (python3 with matplotlib failed: " + (last.empty() ? "exit " + std::to_string(rc) : last) + ")";
  }
  std::filesystem::remove(log);
  return "";
}

std::string image_tag(const std::filesystem::path& png, const std::string& alt) {
  std::ifstream in(png, std::ios::binary);
  if (!in) return "";
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return "<img alt=\"" + html_escape(alt) + "\" src=\"data:image/png;base64," + base64(bytes.str()) + "\">";
}

std::string number_cell(const nlohmann::json& x, int digits = 4) {
  return x.is_null() ? "not certified" : format_number(x.get<double>(), digits);
}

bool is_part_entry(const nlohmann::json& m) { return m.value("kind", "") == "part"; }

// The volume cells of a solid: mesh, OCCT and relative error (closed, valid B-rep solids only).
std::string volume_cells(const nlohmann::json& validation, const nlohmann::json& check) {
  for (const nlohmann::json& v : validation["volumes"]) {
    if (v["solid"] != check["solid"]) continue;
    return "<td>" +
           (v["mesh_volume"].is_null() ? std::string("mesh open") : format_number(v["mesh_volume"].get<double>(), 6)) +
           "</td><td>" + format_number(v["occt_volume"].get<double>(), 6) + "</td><td>" +
           (v["relative_error"].is_null() ? std::string("-") : format_number(v["relative_error"].get<double>(), 3)) +
           "</td>";
  }
  return "<td>-</td><td>-</td><td>-</td>";
}

// One part mesh of `sagitta run` (app::part_run_json): its per-solid and per-face tables. A face
// shows a certified bound only when the certificate covers it; otherwise its reason.
void write_part_mesh(std::ostringstream& h, const nlohmann::json& mesh) {
  const nlohmann::json& c = mesh["certificate"];
  h << "<h3>" << html_escape(mesh["scheme"].get<std::string>()) << " ("
    << html_escape(mesh["setting"].get<std::string>()) << "): " << mesh["triangles"].get<uint64_t>() << " triangles, "
    << (mesh["certified"].get<bool>()
            ? "certified on every face, Hausdorff &le; " + format_number(c["hausdorff"]["upper"].get<double>())
            : "not certified (" + std::to_string(c["faces_certified"].get<int>()) + " of " +
                  std::to_string(mesh["faces"].get<size_t>()) + " faces)")
    << "</h3>\n<table><tr><th>solid</th><th>triangles</th><th class=\"l\">closed</th><th>open edges (model "
       "boundary)</th>"
       "<th>cracks</th><th>T-junctions</th><th>non-manifold</th><th>&chi;</th><th>mesh volume</th><th>OCCT volume</th>"
       "<th>relative error</th></tr>\n";
  for (const nlohmann::json& s : mesh["validation"]["solid_checks"]) {
    const int solid = s["solid"].get<int>();
    h << "<tr><td>" << (solid < 0 ? std::string("none") : std::to_string(solid)) << "</td><td>"
      << s["triangles"].get<uint64_t>() << "</td><td class=\"l\">" << (s["closed"].get<bool>() ? "closed" : "open")
      << "</td><td>" << s["open_edges"].get<uint64_t>() << " (" << s["model_boundary_edges"].get<uint64_t>()
      << ")</td><td>" << s["crack_edges"].get<uint64_t>() << "</td><td>" << s["t_junctions"].get<uint64_t>()
      << "</td><td>" << s["non_manifold_edges"].get<uint64_t>() << "</td><td>"
      << s["euler_characteristic"].get<int64_t>() << "</td>" << volume_cells(mesh["validation"], s) << "</tr>\n";
  }
  h << "</table>\n<table class=\"faces\"><tr><th class=\"l\">face</th><th class=\"l\">surface</th><th "
       "class=\"l\">trimmed</th>"
       "<th>solid</th><th>triangles</th><th class=\"l\">route</th><th>lower bound</th><th "
       "class=\"l\">certificate</th></tr>\n";
  for (const nlohmann::json& f : mesh["face_list"]) {
    h << "<tr><td class=\"l\">" << html_escape(f["face"].get<std::string>()) << "</td><td class=\"l\">"
      << html_escape(f["surface"].get<std::string>()) << "</td><td class=\"l\">"
      << (f["trimmed"].get<bool>() ? "yes" : "no") << "</td><td>" << f["solid"].get<int>() << "</td><td>"
      << f["triangles"].get<uint64_t>() << "</td><td class=\"l\">" << html_escape(f.value("route", std::string()))
      << "</td><td>" << format_number(f.value("lower", 0.0)) << "</td><td class=\"l\">"
      << (f["certified"].get<bool>() ? "certified, &le; " + format_number(f["upper"].get<double>())
                                     : "not certified: " + html_escape(f["reason"].get<std::string>()))
      << "</td></tr>\n";
  }
  h << "</table>\n";
}

// A whole CAD part's section (app::part_report_entry): the level sweep, and the meshes `sagitta
// run` made. The Hausdorff column is filled only for levels where every face is certified.
void write_part_section(std::ostringstream& h, const nlohmann::json& m, size_t k, const std::filesystem::path& dir,
                        bool plots) {
  h << "<h2>" << html_escape(m["name"].get<std::string>()) << " &mdash; whole CAD part: " << m["faces"].get<size_t>()
    << " faces (" << m["faces_trimmed"].get<int>() << " trimmed), " << m["solids"].get<size_t>() << " solids ("
    << m["closed_solids"].get<size_t>()
    << " closed and valid)</h2>\n<p class=\"note\">Every face meshed into one mesh "
       "watertight across faces (uniform levels). A level's Hausdorff bound is certified only when every face is "
       "(trimmed faces through their loops and the slivers at their trimming curves, docs/VALIDATION.md).</p>\n";
  if (plots) {
    h << "<div class=\"plots\">"
      << image_tag(dir / ("model_" + std::to_string(k) + "_triangles.png"), "triangles against level")
      << image_tag(dir / ("model_" + std::to_string(k) + "_time.png"), "tessellation time against level") << "</div>\n";
  }
  h << "<h3>Levels</h3>\n<table><tr><th>level</th><th>triangles</th><th>tessellation ms</th><th>faces tessellated</th>"
       "<th>closed solids closed</th><th class=\"l\">watertight</th><th>certified faces</th>"
       "<th class=\"l\">certified Hausdorff</th></tr>\n";
  for (const nlohmann::json& r : m["levels"]) {
    h << "<tr><td>" << r["level"].get<int>() << "</td><td>" << r["triangles"].get<uint64_t>() << "</td><td>"
      << format_number(1e3 * r["seconds"].get<double>()) << "</td><td>" << r["faces_tessellated"].get<int>() << "/"
      << r["faces"].get<size_t>() << "</td><td>" << r["closed_solid_meshes"].get<size_t>() << "/"
      << r["closed_solids"].get<size_t>() << "</td><td class=\"l\">" << (r["watertight"].get<bool>() ? "yes" : "no")
      << "</td><td>" << r["faces_certified"].get<int>() << "/" << r["faces"].get<size_t>() << "</td><td class=\"l\">";
    if (r["certified_hausdorff"].is_null()) {
      h << "not certified (" << html_escape(r["not_certified_reason"].get<std::string>()) << ")";
    } else {
      h << "[" << format_number(r["certified_hausdorff"]["lower"].get<double>()) << ", "
        << format_number(r["certified_hausdorff"]["upper"].get<double>()) << "]";
    }
    h << "</td></tr>\n";
  }
  h << "</table>\n";
  if (m.contains("fit")) {  // the whole-part fit (docs/FITTING.md)
    const nlohmann::json& f = m["fit"];
    h << "<h3>Fit to a certified error of " << format_number(f["target_error"].get<double>())
      << "</h3>\n<table><tr><th>triangles</th><th>segments (largest face)</th><th>edge tolerance</th>"
         "<th class=\"l\">certified Hausdorff</th><th>faces over the ratio limits</th><th>fit s</th></tr>\n<tr><td>"
      << f["triangles"].get<uint64_t>() << "</td><td>" << f["segments"].get<int>() << "</td><td>"
      << format_number(f["edge_tolerance"].get<double>()) << "</td><td class=\"l\">";
    if (f["certified"].get<bool>()) {
      h << "[" << format_number(f["certified_lower_bound"].get<double>()) << ", "
        << format_number(f["certified_error"].get<double>()) << "]";
    } else {
      h << "not certified";
    }
    h << (f["met"].get<bool>() ? "" : " (target not met: " + html_escape(f["reason"].get<std::string>()) + ")")
      << "</td><td>" << f["faces_over_ratio_limits"].get<int>() << "/" << f["faces"].get<size_t>() << "</td><td>"
      << format_number(f["seconds"].get<double>())
      << "</td></tr>\n</table>\n<p class=\"note\">Each face its own "
         "uniform density and its edges one tolerance, the fewest triangles whose certified error is at most the "
         "target "
         "on every face; then faces whose interval is wider than 1.5&times; (1.1&times; untrimmed) their lower bound "
         "are refined where that helps.</p>\n";
  }
  if (!m["skipped"].empty()) {
    h << "<p class=\"note\">Left out: ";
    for (size_t i = 0; i < m["skipped"].size(); ++i)
      h << (i ? "; " : "") << html_escape(m["skipped"][i].get<std::string>());
    h << "</p>\n";
  }
  for (const nlohmann::json& mesh : m["meshes"]) write_part_mesh(h, mesh);
}

}  // namespace

std::string write_trade_report(const nlohmann::json& report, const std::string& out_dir) {
  std::filesystem::create_directories(out_dir);
  const std::filesystem::path dir(out_dir);
  const std::string json_path = (dir / "report.json").string();
  write_json(json_path, report);
  const std::string plot_problem = make_plots(json_path, out_dir);
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>Sagitta trade report</title>\n<style>\n"
       "body{font-family:sans-serif;max-width:1300px;margin:24px auto;color:#222;line-height:1.45}\n"
       "h1{font-size:26px}h2{font-size:21px;border-bottom:2px solid #ccc;padding-bottom:4px;margin-top:36px}\n"
       "h3{font-size:17px}table{border-collapse:collapse;font-size:14px;margin:8px 0}\n"
       "td,th{border:1px solid #bbb;padding:3px 8px;text-align:right}th{background:#eee}td.l,th.l{text-align:left}\n"
       "tr.front td{background:#fff4c2;font-weight:bold}.plots{display:flex;flex-wrap:wrap;gap:12px}\n"
       ".plots img{width:640px;border:1px solid #ddd}.notice{background:#fde2e2;padding:8px;border:1px solid #e99}\n"
       ".note{color:#555;font-size:14px}\n</style></head><body>\n"
       "<h1>Sagitta: speed against accuracy</h1>\n<p class=\"note\">Error = "
    << html_escape(report["error"].get<std::string>()) << ". Time = " << html_escape(report["time"].get<std::string>());
  const bool parts_only = std::all_of(report["models"].begin(), report["models"].end(), is_part_entry);
  if (parts_only)
    h << ".</p>\n";
  else
    h << ". Highlighted rows lie on the Pareto front of error against triangles (no other setting of any scheme has "
         "fewer "
         "or equal triangles and a smaller error). Fits per scheme (Ceres, Huber loss on log error): certified_error = "
         "C &middot; "
         "T<sup>p</sup>, for PN F + C &middot; T<sup>p</sup> (PN converges to the PN surface of its base mesh, not to "
         "the exact surface). "
         "Settings whose surface-to-mesh bound could not be certified show &lsquo;not certified&rsquo; and are left "
         "out of fits and fronts.</p>\n";
  if (!plot_problem.empty()) h << "<p class=\"notice\">" << html_escape(plot_problem) << "</p>\n";
  for (size_t k = 0; k < report["models"].size(); ++k) {
    const nlohmann::json& m = report["models"][k];
    if (is_part_entry(m)) {
      write_part_section(h, m, k, dir, plot_problem.empty());
      continue;
    }
    h << "<h2>" << html_escape(m["name"].get<std::string>()) << " &mdash; " << m["patches"].get<size_t>()
      << " patches, box diagonal " << format_number(m["box_diagonal"].get<double>()) << "</h2>\n";
    if (plot_problem.empty()) {
      h << "<div class=\"plots\">"
        << image_tag(dir / ("model_" + std::to_string(k) + "_triangles.png"), "certified error against triangles")
        << image_tag(dir / ("model_" + std::to_string(k) + "_time.png"), "certified error against tessellation time") << "</div>\n";
    }
    h << "<h3>Verdict per scheme (reference error " << format_number(m["reference_error"].get<double>()) << ")</h3>\n"
      << "<table><tr><th class=\"l\">scheme</th><th class=\"l\">fitted model (T = triangles)</th><th>largest |log residual|</th>"
         "<th>triangles for the reference error</th><th class=\"l\">verdict</th></tr>\n";
    for (const auto& [scheme, s] : m["schemes"].items()) {
      h << "<tr><td class=\"l\"><b>" << scheme << "</b></td>";
      if (s.contains("fit")) {
        double worst = 0.0;
        for (double r : s["fit"]["log_residuals"]) worst = std::max(worst, std::abs(r));
        h << "<td class=\"l\">" << (s["fit"].contains("F") ? format_number(s["fit"]["F"].get<double>()) + " + " : "")
          << format_number(s["fit"]["C"].get<double>()) << " &middot; T<sup>" << format_number(s["fit"]["p"].get<double>())
          << "</sup></td><td>" << format_number(worst, 2) << "</td><td>"
          << (s["triangles_at_reference_error"].is_null() ? std::string("unreachable")
                                                          : format_number(s["triangles_at_reference_error"].get<double>(), 6))
          << "</td>";
      } else {
        h << "<td>-</td><td>-</td><td>-</td>";
      }
      h << "<td class=\"l\">" << html_escape(s["verdict"].get<std::string>()) << "</td></tr>\n";
    }
    h << "</table>\n<h3>Measurements</h3>\n<table><tr><th class=\"l\">scheme</th><th class=\"l\">setting</th><th>triangles</th>"
         "<th>tessellation ms</th><th>certified lower</th><th>certified upper</th><th>certify s</th></tr>\n";
    const auto& front = m["pareto_triangles"];
    for (size_t i = 0; i < m["points"].size(); ++i) {
      const nlohmann::json& p = m["points"][i];
      const bool on_front = std::find(front.begin(), front.end(), nlohmann::json(i)) != front.end();
      h << "<tr" << (on_front ? " class=\"front\"" : "") << "><td class=\"l\">" << p["scheme"].get<std::string>()
        << "</td><td class=\"l\">" << html_escape(p["setting"].get<std::string>()) << "</td><td>" << p["triangles"].get<uint64_t>()
        << "</td><td>" << format_number(1e3 * p["seconds"].get<double>()) << "</td><td>" << number_cell(p["lower_bound"])
        << "</td><td>" << number_cell(p["certified_error"]) << "</td><td>" << format_number(p["certify_seconds"].get<double>(), 2)
        << "</td></tr>\n";
    }
    h << "</table>\n";
    if (!m["skipped"].empty()) {
      h << "<p class=\"note\">Left out (more than " << kMaxSweepTriangles << " triangles, or refused): ";
      for (size_t i = 0; i < m["skipped"].size(); ++i) h << (i ? "; " : "") << html_escape(m["skipped"][i].get<std::string>());
      h << "</p>\n";
    }
  }
  h << "</body></html>\n";
  const std::string html_path = (dir / "report.html").string();
  io::write_file_atomic(html_path, h.str());
  return html_path;
}

namespace {

struct ReportCliOptions {
  std::vector<std::string> inputs;
  std::string out_dir;
  double target_error = -1.0;
  bool no_occt = false;
};

void run_report(const ReportCliOptions& o) {
  const std::filesystem::path dir(o.out_dir);
  std::vector<NamedPath> outputs;
  for (const char* file : {"report.json", "report.html", "plot.log"}) outputs.push_back({file, (dir / file).string()});
  for (size_t k = 0; k < std::max<size_t>(o.inputs.size(), 1); ++k) {
    for (const char* plot : {"_triangles.png", "_time.png"}) {
      const std::string file = "model_" + std::to_string(k) + plot;
      outputs.push_back({file, (dir / file).string()});
    }
  }
  check_outputs(outputs, o.inputs);
  // Whole CAD parts are swept by the part mesher (app::part_report_entry), the rest as patch models.
  std::vector<bool> is_part;
  std::vector<NamedModel> models;
  for (const std::string& input : o.inputs) {
    is_part.push_back(occt::is_cad_file(input) && occt::is_whole_part(occt::read_cad_file(input)));
    if (is_part.back()) continue;
    models.push_back({input == "default" ? "default" : std::filesystem::path(input).filename().string(), load_model(input)});
  }
  if (o.inputs.empty()) models.push_back({"default", load_model("")});
  ReportOptions options;
  options.occt = !o.no_occt;
  options.target_error = o.target_error;
  ProgressLine progress("sagitta report");
  options.progress = [&](int done, int total, const std::string& what) { progress.update(done, total, what); };
  nlohmann::json report = build_trade_report(models, options);
  if (std::find(is_part.begin(), is_part.end(), true) != is_part.end()) {
    nlohmann::json merged = nlohmann::json::array();  // in the order of the inputs
    size_t next_model = 0;
    for (size_t k = 0; k < o.inputs.size(); ++k) {
      if (!is_part[k]) {
        merged.push_back(report["models"][next_model++]);
        continue;
      }
      const std::string name = std::filesystem::path(o.inputs[k]).filename().string();
      nlohmann::json entry = app::part_report_entry(o.inputs[k], name, kPartReportLevels, options.progress);
      // The whole-part fit (`sagitta fit PART`) at --target-error, else 1e-3 of the part's box diagonal.
      const double target = o.target_error > 0.0 ? o.target_error : 1e-3 * entry.value("box_diagonal", 0.0);
      if (target > 0.0) {
        const app::PartFit fit = app::fit_part(
            [&](const occt::PartOptions& part_options) { return occt::mesh_part_file(o.inputs[k], part_options); },
            target, CertifyOptions{},
            [&](int step, int segments) {
              if (options.progress)
                options.progress(step, 0, name + ": fit, " + std::to_string(segments) + " segments");
            });
        entry["fit"] = app::part_fit_summary(fit);
      }
      merged.push_back(std::move(entry));
    }
    report["models"] = merged;
  }
  progress.clear();
  const std::string html = write_trade_report(report, o.out_dir);
  std::cout << "sagitta report: " << report["models"].size() << " model(s) -> " << html << " and "
            << (std::filesystem::path(o.out_dir) / "report.json").string() << "\n";
  for (const auto& m : report["models"]) {
    if (is_part_entry(m)) {
      for (const auto& r : m["levels"]) {
        std::cout << "  " << m["name"].get<std::string>() << " level " << r["level"].get<int>() << ": "
                  << r["triangles"].get<uint64_t>() << " triangles, closed solids closed "
                  << r["closed_solid_meshes"].get<size_t>() << "/" << r["closed_solids"].get<size_t>() << ", "
                  << (r["certified"].get<bool>()
                          ? "certified Hausdorff <= " + format_number(r["certified_hausdorff"]["upper"].get<double>())
                          : "not certified (" + std::to_string(r["faces_certified"].get<int>()) + " of " +
                                std::to_string(r["faces"].get<size_t>()) + " faces)")
                  << "\n";
      }
      if (m.contains("fit")) {
        const nlohmann::json& f = m["fit"];
        std::cout << "  " << m["name"].get<std::string>() << " fit to "
                  << format_number(f["target_error"].get<double>()) << ": " << f["triangles"].get<uint64_t>()
                  << " triangles, "
                  << (f["certified"].get<bool>()
                          ? "certified Hausdorff <= " + format_number(f["certified_error"].get<double>())
                          : std::string("not certified"))
                  << (f["met"].get<bool>() ? " (meets the target)" : " (MISSES the target)") << "\n";
      }
      continue;
    }
    for (const auto& [scheme, s] : m["schemes"].items()) {
      std::cout << "  " << m["name"].get<std::string>() << " " << scheme << ": " << s["verdict"].get<std::string>() << "\n";
    }
  }
}

}  // namespace

Command register_report(CLI::App& app) {
  auto o = std::make_shared<ReportCliOptions>();
  CLI::App* cmd = app.add_subcommand("report", "Certified error against triangles and time for every scheme: report.json + report.html");
  cmd->add_option("inputs", o->inputs,
                  "Patch files (.bpt, .rib) or 'default'; none: the built-in model; whole CAD parts (.step, .iges, "
                  ".brep) are swept over uniform levels 1-4 by the part mesher");
  cmd->add_option("--out", o->out_dir, "Output folder for report.json, report.html and the plots")->required();
  cmd->add_option("--target-error", o->target_error, "Reference error for the verdicts (default: 1e-3 of each model's box diagonal)");
  cmd->add_flag("--no-occt", o->no_occt, "Leave out OCCT BRepMesh (the peer)");
  return {cmd, [o] { run_report(*o); }};
}

}  // namespace sagitta::cli
