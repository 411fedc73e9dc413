// A CSV file that is never half-written: an OutputFile (output_file.h), renamed into place by
// Commit(). A writer destroyed without Commit() removes its temporary file.
#ifndef MJSTEPPER_TOOLS_CSV_WRITER_H_
#define MJSTEPPER_TOOLS_CSV_WRITER_H_

#include <span>
#include <string>
#include <vector>

#include "output_file.h"

namespace mjstepper::tools {

class CsvWriter {
 public:
  /// Throws std::runtime_error when `path` may not be written or the temporary cannot be created.
  /// `digits`: significant digits per value (17 round-trips a double exactly; logs use 10).
  CsvWriter(std::string path, const std::vector<std::string>& header, int digits = 10);
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  void Row(std::span<const double> values);
  /// Flushes, closes and renames into place; throws std::runtime_error on any I/O error.
  void Commit();

 private:
  OutputFile file_;
  std::string buffer_;
  int digits_ = 10;
};

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_CSV_WRITER_H_
