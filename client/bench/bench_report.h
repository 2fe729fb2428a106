// The outputs of a bench run: bench.json (everything, for scripts and the
// plot), bench.csv (one row per configuration, for spreadsheets) and the
// summary table printed by `pbgi bench`. Columns are described in
// docs/benchmarks.md.
//
// Thread-safety: pure functions (the writers touch only their file).
#pragma once

#include "client/bench/bench_result.h"

#include <filesystem>
#include <string>

namespace pbgi::bench {

// The JSON document of `result` (schema "pbgi.bench/1").
std::string bench_json(const BenchResult& result);

// The CSV table: a header, then one line per row. Parameter columns are the
// union of all rows' parameter names (empty where a row has none).
std::string bench_csv(const BenchResult& result);

// Human-readable summary: the table of rows, then the equal-error figures.
std::string bench_summary(const BenchResult& result);

// Writes `text` to `path` through a temporary file and a rename. Throws
// IoError naming the file.
void write_text_file(const std::filesystem::path& path, const std::string& text);

}  // namespace pbgi::bench
