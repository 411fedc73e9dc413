// A CSV file that is never half-written: rows go to "<path>.tmp", renamed to <path> by Commit().
// A writer destroyed without Commit() removes its temporary file.
#ifndef MJSTEPPER_TOOLS_CSV_WRITER_H_
#define MJSTEPPER_TOOLS_CSV_WRITER_H_

#include <cstdio>
#include <span>
#include <string>
#include <vector>

namespace mjstepper::tools {

class CsvWriter {
 public:
  /// Throws std::runtime_error when the temporary file cannot be created.
  CsvWriter(std::string path, const std::vector<std::string>& header);
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
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_CSV_WRITER_H_
