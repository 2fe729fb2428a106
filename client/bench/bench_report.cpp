#include "client/bench/bench_report.h"

#include "client/bench/json_writer.h"
#include "common/errors.h"

#include <fmt/format.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <set>
#include <system_error>

namespace pbgi::bench {
namespace {

void write_params(JsonWriter& w, const std::vector<Param>& params) {
  w.begin_object();
  for (const auto& [k, v] : params) w.field(k, v);
  w.end_object();
}

void write_aov(JsonWriter& w, const AovError& a) {
  w.begin_object();
  w.field("mse", a.error.mse);
  w.field("rmse", a.error.rmse);
  w.field("psnr", a.error.psnr);
  w.field("rel_mse", a.error.rel_mse);
  w.field("rel_rmse", a.error.rel_rmse);
  w.field("bias", a.error.bias);
  w.field("pdiff_pixels", a.pdiff_pixels);
  w.field("pdiff_fraction", a.pdiff_fraction);
  w.field("values", a.error.values);
  w.field("nonfinite", a.error.nonfinite);
  w.end_object();
}

void write_equal_error(JsonWriter& w, const EqualError& e) {
  w.begin_object();
  w.field("valid", e.valid);
  w.field("note", e.note);
  w.field("pbgi", e.pbgi_name);
  w.field("pbgi_mse", e.pbgi_mse);
  w.field("noise_floor", e.noise_floor);
  w.field("pbgi_render_seconds", e.pbgi_render_seconds);
  w.field("pbgi_total_seconds", e.pbgi_total_seconds);
  w.field("pbgi_render_cpu_seconds", e.pbgi_render_cpu_seconds);
  w.field("pbgi_total_cpu_seconds", e.pbgi_total_cpu_seconds);
  w.field("path_spp", e.path_spp);
  w.field("path_seconds", e.path_seconds);
  w.field("path_cpu_seconds", e.path_cpu_seconds);
  w.field("extrapolated", e.extrapolated);
  w.field("speedup", e.speedup);
  w.field("speedup_including_build", e.speedup_including_build);
  w.field("speedup_cpu", e.speedup_cpu);
  w.field("default_curve_seconds", e.default_curve_seconds);
  w.field("default_curve_cpu_seconds", e.default_curve_cpu_seconds);
  w.field("speedup_over_default", e.speedup_over_default);
  w.field("speedup_over_default_cpu", e.speedup_over_default_cpu);
  w.end_object();
}

std::string csv_cell(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
  return out + "\"";
}

std::string num(double v) { return std::isfinite(v) ? fmt::format("{}", v) : ""; }

std::string find_param(const std::vector<Param>& params, const std::string& key) {
  for (const auto& [k, v] : params)
    if (k == key) return v;
  return "";
}

std::string equal_error_text(const EqualError& e) {
  if (!e.valid) return fmt::format("{}: no equal-error figure: {}\n", e.aov, e.note);
  std::string s = fmt::format(
      "{}: PBGI default {} has MSE {:.4g} ({:.4g} after removing the reference's noise {:.3g}):\n"
      "  render {:.3f} s wall / {:.3f} s CPU ({:.3f} s / {:.3f} s with build and load).\n"
      "  The path tracer reaches that MSE at {:.1f} spp in {:.3f} s wall / {:.3f} s CPU ({}).\n"
      "  Speed-up of PBGI: {:.2f}x render only, {:.2f}x including build; {:.2f}x in CPU time.\n",
      e.aov, e.pbgi_name, e.pbgi_mse, e.pbgi_mse - e.noise_floor, e.noise_floor,
      e.pbgi_render_seconds, e.pbgi_render_cpu_seconds, e.pbgi_total_seconds,
      e.pbgi_total_cpu_seconds, e.path_spp, e.path_seconds, e.path_cpu_seconds,
      e.extrapolated ? "EXTRAPOLATED beyond the sweep with MSE ~ 1/spp"
                     : "interpolated log-log between sweep points",
      e.speedup, e.speedup_including_build, e.speedup_cpu);
  if (e.noise_floor > 0.25 * e.pbgi_mse)
    s += fmt::format("  Warning: the reference's own noise is {:.0f}% of this MSE; raise the "
                     "reference spp for a firmer figure.\n",
                     100 * e.noise_floor / e.pbgi_mse);
  return s;
}

// One line per equal-error point: its indirect MSE and CPU time, the path
// tracer's CPU time there and, off the default's curve, that curve's.
std::string equal_points_table(const BenchResult& r) {
  std::string s = fmt::format("indirect, equal error (CPU seconds):\n{:<40} {:>10} {:>8} {:>9} {:>8} {:>9} {:>8}\n",
                              "configuration", "MSE", "CPU s", "path CPU", "x path", "curve CPU",
                              "x curve");
  for (const EqualError& e : r.equal_points) {
    const std::string path = e.valid ? fmt::format("{:9.3f} {:7.2f}x{}", e.path_cpu_seconds,
                                                   e.speedup_cpu, e.extrapolated ? "*" : " ")
                                     : fmt::format("{:>9} {:>8} ", "-", "-");
    const std::string curve = e.default_curve_cpu_seconds > 0
                                  ? fmt::format("{:9.3f} {:7.2f}x", e.default_curve_cpu_seconds,
                                                e.speedup_over_default_cpu)
                                  : fmt::format("{:>9} {:>8}", "-", "-");
    s += fmt::format("{:<40} {:10.4g} {:8.3f} {} {}\n", e.pbgi_name, e.pbgi_mse,
                     e.pbgi_render_cpu_seconds, path, curve);
  }
  return s + "(* path tracer extrapolated with MSE ~ 1/spp; curve: the default configuration's "
             "method and payload over its settings, '-' = outside its error range)\n";
}

}  // namespace

std::string bench_json(const BenchResult& r) {
  JsonWriter w;
  w.begin_object();
  w.field("schema", "pbgi.bench/1");
  w.field("scene", r.scene);
  w.field("scene_hash", r.scene_hash);
  w.field("camera", r.camera);
  w.field("width", r.width);
  w.field("height", r.height);
  w.field("max_depth", r.max_depth);
  w.field("threads", r.threads);
  w.field("wall_seconds", r.wall_seconds);

  w.key("reference");
  w.begin_object();
  w.field("spp", r.reference.spp);
  w.field("seed", r.reference.seed);
  w.field("seconds", r.reference.seconds);
  w.field("cpu_seconds", r.reference.cpu_seconds);
  w.field("cached", r.reference.cached);
  w.field("key", r.reference.key);
  w.field("file", r.reference.file.string());
  w.field("noise_mse_indirect", r.reference.noise_mse_indirect);
  w.field("noise_mse_beauty", r.reference.noise_mse_beauty);
  w.end_object();

  w.key("builds");
  w.begin_array();
  for (const BuildRecord& b : r.builds) {
    w.begin_object();
    w.field("name", b.name);
    w.key("params");
    write_params(w, b.params);
    w.key("facts");
    write_params(w, b.facts);
    w.field("build_seconds", b.build_seconds);
    w.field("load_seconds", b.load_seconds);
    w.field("build_cpu_seconds", b.build_cpu_seconds);
    w.field("load_cpu_seconds", b.load_cpu_seconds);
    w.end_object();
  }
  w.end_array();

  w.key("rows");
  w.begin_array();
  for (const BenchRow& row : r.rows) {
    w.begin_object();
    w.field("method", row.method);
    w.field("name", row.name);
    w.field("series", row.series);
    w.field("build", row.build);
    w.field("spp", row.spp);
    w.field("is_default", row.is_default);
    w.field("equal_error_point", row.equal_error_point);
    w.field("default_curve", row.default_curve);
    w.key("params");
    write_params(w, row.params);
    w.field("render_seconds", row.render_seconds);
    w.field("build_seconds", row.build_seconds);
    w.field("total_seconds", row.total_seconds);
    w.field("render_cpu_seconds", row.render_cpu_seconds);
    w.field("build_cpu_seconds", row.build_cpu_seconds);
    w.field("total_cpu_seconds", row.total_cpu_seconds);
    w.key("indirect");
    write_aov(w, row.indirect);
    w.key("beauty");
    write_aov(w, row.beauty);
    w.field("pareto_indirect", row.pareto_indirect);
    w.field("pareto_beauty", row.pareto_beauty);
    w.end_object();
  }
  w.end_array();

  w.key("equal_error");
  w.begin_object();
  w.key("indirect");
  write_equal_error(w, r.equal_indirect);
  w.key("beauty");
  write_equal_error(w, r.equal_beauty);
  w.end_object();

  w.key("equal_error_points");
  w.begin_array();
  for (const EqualError& e : r.equal_points) write_equal_error(w, e);
  w.end_array();

  w.key("warnings");
  w.begin_array();
  for (const auto& warning : r.warnings) w.value(warning);
  w.end_array();
  w.end_object();
  return w.str() + "\n";
}

std::string bench_csv(const BenchResult& r) {
  // Parameter columns: the union of names, in order of first appearance.
  std::vector<std::string> param_cols;
  std::set<std::string> seen;
  for (const BenchRow& row : r.rows)
    for (const auto& [k, v] : row.params)
      if (seen.insert(k).second) param_cols.push_back(k);

  std::string out = "method,name,series,build";
  // (Two appends rather than "," + cell: GCC 12 warns falsely on the latter.)
  for (const auto& c : param_cols) {
    out += ',';
    out += csv_cell(c);
  }
  out += ",is_default,build_seconds,render_seconds,total_seconds,build_cpu_seconds,"
         "render_cpu_seconds,total_cpu_seconds";
  for (const char* aov : {"indirect", "beauty"})
    out += fmt::format(",{0}_mse,{0}_rmse,{0}_psnr,{0}_relmse,{0}_relrmse,{0}_pdiff_pixels,{0}_pdiff_fraction",
                       aov);
  out += ",pareto_indirect,pareto_beauty\n";

  for (const BenchRow& row : r.rows) {
    out += fmt::format("{},{},{},{}", csv_cell(row.method), csv_cell(row.name),
                       csv_cell(row.series), csv_cell(row.build));
    for (const auto& c : param_cols) {
      out += ',';
      out += csv_cell(find_param(row.params, c));
    }
    out += fmt::format(",{},{},{},{},{},{},{}", row.is_default ? 1 : 0, num(row.build_seconds),
                       num(row.render_seconds), num(row.total_seconds),
                       num(row.build_cpu_seconds), num(row.render_cpu_seconds),
                       num(row.total_cpu_seconds));
    for (const AovError* a : {&row.indirect, &row.beauty})
      out += fmt::format(",{},{},{},{},{},{},{}", num(a->error.mse), num(a->error.rmse),
                         num(a->error.psnr), num(a->error.rel_mse), num(a->error.rel_rmse), a->pdiff_pixels,
                         num(a->pdiff_fraction));
    out += fmt::format(",{},{}\n", row.pareto_indirect ? 1 : 0, row.pareto_beauty ? 1 : 0);
  }
  return out;
}

std::string bench_summary(const BenchResult& r) {
  std::string s = fmt::format(
      "scene {} ({}), camera {}, {}x{}, max depth {}, {} threads\n"
      "reference: {} spp, seed {:#x}, {:.1f} s ({:.1f} s CPU){}\n\n",
      r.scene, r.scene_hash, r.camera, r.width, r.height, r.max_depth, r.threads, r.reference.spp,
      r.reference.seed, r.reference.seconds, r.reference.cpu_seconds,
      r.reference.cached ? " (cached)" : "");
  for (const BuildRecord& b : r.builds)
    s += fmt::format(
        "build {:<14} {:8.3f} s build, {:6.3f} s load ({:.3f} s CPU)  ({} surfels, {} pages)\n",
        b.name, b.build_seconds, b.load_seconds, b.build_cpu_seconds + b.load_cpu_seconds,
        find_param(b.facts, "surfels"), find_param(b.facts, "pages"));
  if (!r.builds.empty()) s += "\n";

  s += fmt::format(
      "{:<40} {:>8} {:>8} {:>8} {:>8} | {:>10} {:>6} {:>9} {:>6} | {:>10} {:>6} {:>9} {:>6}  {}\n",
      "configuration", "build s", "render s", "total s", "CPU s", "ind MSE", "PSNR", "relMSE",
      "pdiff", "beauty MSE", "PSNR", "relMSE", "pdiff", "flags");
  for (const BenchRow& row : r.rows) {
    std::string flags;
    if (row.is_default) flags += "default ";
    if (row.pareto_indirect) flags += "P-ind ";
    if (row.pareto_beauty) flags += "P-beauty";
    s += fmt::format(
        "{:<40} {:8.3f} {:8.3f} {:8.3f} {:8.3f} | {:10.4g} {:6.2f} {:9.4g} {:6} | {:10.4g} {:6.2f} "
        "{:9.4g} {:6}  {}\n",
        row.name, row.build_seconds, row.render_seconds, row.total_seconds,
        row.render_cpu_seconds, row.indirect.error.mse,
        row.indirect.error.psnr, row.indirect.error.rel_mse, row.indirect.pdiff_pixels,
        row.beauty.error.mse, row.beauty.error.psnr, row.beauty.error.rel_mse,
        row.beauty.pdiff_pixels, flags);
  }
  s += fmt::format("\nreference noise (estimated MSE of the reference itself): indirect {:.3g}, "
                   "beauty {:.3g}\n\n",
                   r.reference.noise_mse_indirect, r.reference.noise_mse_beauty);
  s += equal_error_text(r.equal_indirect);
  s += equal_error_text(r.equal_beauty);
  if (!r.equal_points.empty()) s += fmt::format("\n{}", equal_points_table(r));
  for (const auto& w : r.warnings) s += "warning: " + w + "\n";
  return s;
}

void write_text_file(const std::filesystem::path& path, const std::string& text) {
  const std::filesystem::path tmp = path.string() + ".tmp";
  {
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw IoError(fmt::format("cannot write {}: {}", tmp.string(), std::strerror(errno)));
    f << text;
    f.flush();
    if (!f) throw IoError(fmt::format("cannot write {}: {}", tmp.string(), std::strerror(errno)));
  }
  std::error_code ec;
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw IoError(fmt::format("cannot rename {} to {}: {}", tmp.string(), path.string(), ec.message()));
}

}  // namespace pbgi::bench
