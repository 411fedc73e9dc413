#include "csv_writer.h"

#include <fmt/format.h>

#include <iterator>

namespace mjstepper::tools {

CsvWriter::CsvWriter(std::string path, const std::vector<std::string>& header, int digits)
    : file_(std::move(path)), digits_(digits) {
  for (size_t i = 0; i < header.size(); ++i) {
    buffer_ += header[i];
    buffer_ += i + 1 < header.size() ? ',' : '\n';
  }
}

void CsvWriter::Row(std::span<const double> values) {
  for (size_t i = 0; i < values.size(); ++i) {
    fmt::format_to(std::back_inserter(buffer_), "{:.{}g}{}", values[i], digits_,
                   i + 1 < values.size() ? ',' : '\n');
  }
  if (buffer_.size() > (1 << 20)) {
    file_.Write(buffer_.data(), buffer_.size());
    buffer_.clear();
  }
}

void CsvWriter::Commit() {
  file_.Write(buffer_.data(), buffer_.size());
  buffer_.clear();
  file_.Commit();
}

}  // namespace mjstepper::tools
