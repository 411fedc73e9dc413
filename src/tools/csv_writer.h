// A CSV file that is never half-written: rows go to "<path>.tmp", renamed to <path> by Commit().
// A writer destroyed without Commit() removes its temporary file.
#ifndef MJSTEPPER_TOOLS_CSV_WRITER_H_
#define MJSTEPPER_TOOLS_CSV_WRITER_H_

#include <cstdio>
#include <span>
#include <string>
#include <vector>

namespace mjstepper::tools {

/// Throws std::runtime_error naming `path` when a file cannot be written there: an existing
/// directory, or a parent that cannot be made. Called before long runs, so they fail at once.
void CheckOutputPath(const std::string& path);

/// Renames the finished `tmp` onto `path`; on failure removes `tmp` and throws naming `path`.
void MoveIntoPlace(const std::string& tmp, const std::string& path);

class CsvWriter {
 public:
  /// Throws std::runtime_error when the temporary file cannot be created. `digits`: significant
  /// digits per value (17 round-trips a double exactly; logs use 10 to stay small).
  CsvWriter(std::string path, const std::vector<std::string>& header, int digits = 10);
  ~CsvWriter();
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  void Row(std::span<const double> values);
  /// Flushes, closes and renames into place; throws std::runtime_error on any I/O error.
  void Commit();

 private:
  std::string path_;
  std::string tmp_path_;
  std::FILE* file_ = nullptr;
  std::string buffer_;
  int digits_ = 10;
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_CSV_WRITER_H_
