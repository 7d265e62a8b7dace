#include "sagitta/io/mesh_io.hpp"

#include "sagitta/io/model_io.hpp"

#include <glm/geometric.hpp>

#include <atomic>
#include <cctype>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>
#include <pthread.h>
#include <sys/stat.h>
#include <unistd.h>

namespace sagitta::io {

namespace fs = std::filesystem;

namespace {

// The temporary files of writes in progress, for the signal handler: a slot is claimed (1) while
// its path is copied in, live (2) while the file may exist, free (0) otherwise.
constexpr int kTempSlots = 64;
char temp_paths[kTempSlots][4096];
std::atomic<int> temp_state[kTempSlots];
mode_t process_umask = 022;

void on_fatal_signal(int sig) {
  remove_temp_files();
  ::raise(sig);  // SA_RESETHAND restored the default action: it takes effect when the handler returns
}

// The process's umask: from /proc/self/status where Linux gives it (reading it there changes
// nothing), else by setting and restoring it.
mode_t read_umask() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("Umask:", 0) == 0) return static_cast<mode_t>(std::strtoul(line.c_str() + 6, nullptr, 8));
  }
  const mode_t mask = ::umask(0);
  ::umask(mask);
  return mask;
}

// Once per process: remembers the umask and installs the handler for SIGINT, SIGTERM and SIGHUP
// where the disposition is still the default (an ignored signal or another handler is kept).
void install_temp_cleanup() {
  static std::once_flag once;
  std::call_once(once, [] {
    process_umask = read_umask();
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction old {};
      if (::sigaction(sig, nullptr, &old) != 0 || old.sa_handler != SIG_DFL || (old.sa_flags & SA_SIGINFO)) continue;
      struct sigaction act {};
      act.sa_handler = on_fatal_signal;
      sigemptyset(&act.sa_mask);
      act.sa_flags = SA_RESETHAND;
      ::sigaction(sig, &act, nullptr);
    }
  });
}

// Registers a temporary path; returns its slot, or -1 when all slots are taken (the file is then
// still removed on every error, only not on a signal).
int register_temp(const std::string& path) {
  if (path.size() >= sizeof temp_paths[0]) return -1;
  for (int k = 0; k < kTempSlots; ++k) {
    int expected = 0;
    if (temp_state[k].compare_exchange_strong(expected, 1)) {
      std::memcpy(temp_paths[k], path.c_str(), path.size() + 1);
      temp_state[k].store(2);
      return k;
    }
  }
  return -1;
}

void unregister_temp(int slot) {
  if (slot >= 0) temp_state[slot].store(0);
}

}  // namespace

void remove_temp_files() noexcept {
  for (int k = 0; k < kTempSlots; ++k) {
    if (temp_state[k].load() == 2) ::unlink(temp_paths[k]);
  }
}

void write_file_atomic(const std::string& path, const std::string& bytes) {
  install_temp_cleanup();
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  std::string tmpl = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  // Block the cleanup signals while the file is created and registered, so no handler runs between.
  sigset_t block, previous;
  sigemptyset(&block);
  for (int sig : {SIGINT, SIGTERM, SIGHUP}) sigaddset(&block, sig);
  ::pthread_sigmask(SIG_BLOCK, &block, &previous);
  const int fd = mkstemp(tmpl.data());
  const int create_errno = errno;
  const int slot = fd >= 0 ? register_temp(tmpl) : -1;
  ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (fd < 0) throw InputError(path + ": cannot create a temporary file in " + dir.string() + ": " + std::strerror(create_errno));
  auto give_up = [&](const std::string& what) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    ::unlink(tmpl.c_str());
    unregister_temp(slot);
    throw InputError(path + ": " + what + ": " + why);
  };
  // mkstemp creates mode 0600: a replaced file keeps its mode, a new one gets 0666 minus the umask.
  struct stat existing {};
  const mode_t mode = ::stat(path.c_str(), &existing) == 0 && S_ISREG(existing.st_mode) ? existing.st_mode & 07777
                                                                                          : 0666 & ~process_umask;
  if (::fchmod(fd, mode) != 0) give_up("cannot set the file mode");
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n <= 0) give_up("write failed");
    written += static_cast<size_t>(n);
  }
  if (::fsync(fd) != 0) give_up("write failed");
  if (::close(fd) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmpl.c_str());
    unregister_temp(slot);
    throw InputError(path + ": write failed: " + why);
  }
  if (std::rename(tmpl.c_str(), path.c_str()) != 0) {
    const std::string why = std::strerror(errno);
    ::unlink(tmpl.c_str());
    unregister_temp(slot);
    throw InputError(path + ": cannot rename the temporary file into place: " + why);
  }
  unregister_temp(slot);  // after the rename: a signal in between unlinks a name that is gone
}

namespace {

template <class T>
void put(std::string& out, T value) {
  char b[sizeof(T)];
  std::memcpy(b, &value, sizeof(T));
  out.append(b, sizeof(T));
}

}  // namespace

void detail::write_obj(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options) {
  std::string out;
  out.reserve(mesh.positions.size() * 80 + mesh.triangles.size() * 40);
  out += "# sagitta tessellation: " + std::to_string(mesh.positions.size()) + " vertices, " +
         std::to_string(mesh.triangles.size()) + " triangles\n";
  char line[160];
  for (const Vec3& p : mesh.positions) {
    out.append(line, static_cast<size_t>(std::snprintf(line, sizeof line, "v %.17g %.17g %.17g\n", p.x, p.y, p.z)));
  }
  const bool normals = options.normals && mesh.normals.size() == mesh.positions.size();
  if (normals) {
    for (const Vec3& n : mesh.normals) {
      out.append(line, static_cast<size_t>(std::snprintf(line, sizeof line, "vn %.9g %.9g %.9g\n", n.x, n.y, n.z)));
    }
  }
  for (const Triangle& t : mesh.triangles) {
    const int len = normals ? std::snprintf(line, sizeof line, "f %u//%u %u//%u %u//%u\n", t[0] + 1, t[0] + 1, t[1] + 1,
                                            t[1] + 1, t[2] + 1, t[2] + 1)
                            : std::snprintf(line, sizeof line, "f %u %u %u\n", t[0] + 1, t[1] + 1, t[2] + 1);
    out.append(line, static_cast<size_t>(len));
  }
  write_file_atomic(path, out);
}

void write_ply(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options) {
  const bool normals = options.normals && mesh.normals.size() == mesh.positions.size();
  const bool error = options.face_error && options.face_error->size() == mesh.triangles.size();
  const bool patch = mesh.triangle_patch.size() == mesh.triangles.size();
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment sagitta tessellation\n";
  out += "element vertex " + std::to_string(mesh.positions.size()) + "\n";
  out += "property double x\nproperty double y\nproperty double z\n";
  if (normals) out += "property float nx\nproperty float ny\nproperty float nz\n";
  out += "element face " + std::to_string(mesh.triangles.size()) + "\n";
  out += "property list uchar uint vertex_indices\n";
  if (patch) out += "property uint patch\n";
  if (error) out += "property float error\n";
  out += "end_header\n";
  out.reserve(out.size() + mesh.positions.size() * 36 + mesh.triangles.size() * 21);
  for (size_t k = 0; k < mesh.positions.size(); ++k) {
    const Vec3& p = mesh.positions[k];
    put(out, p.x);
    put(out, p.y);
    put(out, p.z);
    if (normals) {
      put(out, static_cast<float>(mesh.normals[k].x));
      put(out, static_cast<float>(mesh.normals[k].y));
      put(out, static_cast<float>(mesh.normals[k].z));
    }
  }
  for (size_t k = 0; k < mesh.triangles.size(); ++k) {
    put(out, static_cast<uint8_t>(3));
    for (uint32_t v : mesh.triangles[k]) put(out, v);
    if (patch) put(out, mesh.triangle_patch[k]);
    if (error) put(out, (*options.face_error)[k]);
  }
  write_file_atomic(path, out);
}

void write_stl(const Tessellation& mesh, const std::string& path, const MeshWriteOptions&) {
  std::string out(80, ' ');
  std::memcpy(out.data(), "sagitta binary STL", 18);
  put(out, static_cast<uint32_t>(mesh.triangles.size()));
  out.reserve(out.size() + mesh.triangles.size() * 50);
  for (const Triangle& t : mesh.triangles) {
    const Vec3 &a = mesh.positions[t[0]], &b = mesh.positions[t[1]], &c = mesh.positions[t[2]];
    Vec3 n = glm::cross(b - a, c - a);
    const double len = glm::length(n);
    n = len > 0.0 ? n / len : Vec3(0.0);
    for (const Vec3& q : {n, a, b, c}) {
      put(out, static_cast<float>(q.x));
      put(out, static_cast<float>(q.y));
      put(out, static_cast<float>(q.z));
    }
    put(out, static_cast<uint16_t>(0));
  }
  write_file_atomic(path, out);
}

void write_mesh(const Tessellation& mesh, const std::string& path, const MeshWriteOptions& options) {
  const std::string ext = file_extension(path);
  if (ext == ".obj") return detail::write_obj(mesh, path, options);
  if (ext == ".ply") return write_ply(mesh, path, options);
  if (ext == ".stl") return write_stl(mesh, path, options);
  throw InputError(path + ": unknown mesh type (expected .obj, .ply or .stl)");
}

}  // namespace sagitta::io
