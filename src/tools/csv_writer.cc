#include "csv_writer.h"

#include <fmt/format.h>

#include <cstdio>
#include <filesystem>
#include <iterator>
#include <stdexcept>

namespace mjstepper::tools {

void CheckOutputPath(const std::string& path) {
  if (path.empty()) throw std::runtime_error("an output path is empty");
  std::error_code error;
  if (std::filesystem::is_directory(path, error)) {
    throw std::runtime_error(fmt::format("cannot write {}: it is a directory", path));
  }
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  if (!parent.empty() && !std::filesystem::create_directories(parent, error) && error) {
    throw std::runtime_error(fmt::format("cannot write {}: {}", path, error.message()));
  }
}

void MoveIntoPlace(const std::string& tmp, const std::string& path) {
  std::error_code error;
  std::filesystem::rename(tmp, path, error);
  if (error) {
    std::remove(tmp.c_str());
    throw std::runtime_error(fmt::format("cannot write {}: {}", path, error.message()));
  }
}

CsvWriter::CsvWriter(std::string path, const std::vector<std::string>& header, int digits)
    : path_(std::move(path)), tmp_path_(path_ + ".tmp"), digits_(digits) {
  CheckOutputPath(path_);
  file_ = std::fopen(tmp_path_.c_str(), "w");
  if (file_ == nullptr) throw std::runtime_error(fmt::format("cannot write {}", tmp_path_));
  for (size_t i = 0; i < header.size(); ++i) {
    buffer_ += header[i];
    buffer_ += i + 1 < header.size() ? ',' : '\n';
  }
}

CsvWriter::~CsvWriter() {
  if (file_ != nullptr) {
    std::fclose(file_);
    std::remove(tmp_path_.c_str());
  }
}

void CsvWriter::Row(std::span<const double> values) {
  for (size_t i = 0; i < values.size(); ++i) {
    fmt::format_to(std::back_inserter(buffer_), "{:.{}g}{}", values[i], digits_,
                   i + 1 < values.size() ? ',' : '\n');
  }
  if (buffer_.size() > (1 << 20)) {
    std::fwrite(buffer_.data(), 1, buffer_.size(), file_);
    buffer_.clear();
  }
}

void CsvWriter::Commit() {
  const bool wrote = std::fwrite(buffer_.data(), 1, buffer_.size(), file_) == buffer_.size();
  buffer_.clear();
  const bool closed = std::fclose(file_) == 0;
  file_ = nullptr;
  if (!wrote || !closed) {
    std::remove(tmp_path_.c_str());
    throw std::runtime_error(fmt::format("error writing {}", tmp_path_));
  }
  MoveIntoPlace(tmp_path_, path_);
}

}  // namespace mjstepper::tools
