#include "sagitta/occt/cad.hpp"
#include "sagitta/mesh_check.hpp"
#include "sagitta/uniform.hpp"
#include <iostream>
#include <map>
int main(int argc, char** argv) {
  using namespace sagitta;
  for (int a = 1; a < argc; ++a) {
    try {
      auto cad = occt::read_cad_file(argv[a]);
      std::map<std::string,int> types, reasons;
      for (auto& f : cad.faces) { types[f.surface_type + "/" + f.status]++; if (!f.reason.empty()) reasons[f.reason]++; }
      std::cout << argv[a] << ": faces " << cad.faces.size() << " tess " << cad.faces_tessellated << " trimmed " << cad.faces_trimmed
                << " skipped " << cad.faces_skipped << " bezier " << cad.bezier_patches << " model " << cad.model.patches.size()
                << " snapped " << cad.snapped_patches << " max_snap " << cad.max_snap << " tol " << cad.snap_tolerance << "\n";
      for (auto& [k, v] : types) std::cout << "  " << k << ": " << v << "\n";
      for (auto& [k, v] : reasons) std::cout << "  reason " << k << ": " << v << "\n";
      if (!cad.model.patches.empty()) {
        Topology t = build_topology(cad.model);
        std::cout << "  topo shared " << t.shared_edges() << " free " << t.free_edges() << " nonman " << t.nonmanifold_edges()
                  << " collapsed " << t.collapsed_sides() << " near_misses " << t.near_misses.size() << "\n";
        for (size_t k = 0; k < t.near_misses.size() && k < 12; ++k) {
          const auto& m = t.near_misses[k];
          std::cout << "    near miss: face " << cad.patch_face[m.a.patch] + 1 << " patch " << m.a.patch << " " << side_name(m.a.side)
                    << " / face " << cad.patch_face[m.b.patch] + 1 << " patch " << m.b.patch << " " << side_name(m.b.side)
                    << " distance " << m.distance << "\n";
        }
      }
    } catch (const std::exception& e) { std::cout << "ERR " << e.what() << "\n"; }
  }
}
