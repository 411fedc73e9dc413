#include "video_writer.h"

#include <fmt/format.h>
#include <png.h>

#include <cstdio>
#include <stdexcept>

#include "csv_writer.h"

namespace mjstepper::tools {

VideoWriter::VideoWriter(std::string path, int width, int height, double fps)
    : path_(std::move(path)), tmp_path_(path_ + ".tmp.mp4"), width_(width), height_(height) {
  CheckOutputPath(path_);
  // yuv420p needs even sizes: the scale filter rounds down by at most one pixel.
  const std::string command = fmt::format(
      "ffmpeg -loglevel error -y -f rawvideo -pix_fmt rgb24 -s {}x{} -r {} -i - "
      "-vf 'scale=trunc(iw/2)*2:trunc(ih/2)*2' -c:v libx264 -preset veryfast -crf 26 "
      "-pix_fmt yuv420p -movflags +faststart '{}'",
      width, height, fps, tmp_path_);
  pipe_ = popen(command.c_str(), "w");
  if (pipe_ == nullptr) throw std::runtime_error(fmt::format("cannot start: {}", command));
}

VideoWriter::~VideoWriter() {
  if (pipe_ != nullptr) {
    pclose(pipe_);
    std::remove(tmp_path_.c_str());
  }
}

void VideoWriter::Write(const std::vector<std::uint8_t>& rgb) {
  if (std::fwrite(rgb.data(), 1, rgb.size(), pipe_) != rgb.size()) {
    throw std::runtime_error(fmt::format("ffmpeg stopped taking frames for {}", path_));
  }
  ++frames_;
}

void VideoWriter::Finish() {
  const int status = pclose(pipe_);
  pipe_ = nullptr;
  if (status != 0) {
    std::remove(tmp_path_.c_str());
    throw std::runtime_error(fmt::format("ffmpeg failed writing {} (status {})", path_, status));
  }
  MoveIntoPlace(tmp_path_, path_);
}

void WritePng(const std::string& path, const std::vector<std::uint8_t>& rgb, int width,
              int height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = width;
  image.height = height;
  image.format = PNG_FORMAT_RGB;
  image.flags = PNG_IMAGE_FLAG_FAST;  // lighter compression: frames are many and transient
  const std::string tmp = path + ".tmp";
  if (!png_image_write_to_file(&image, tmp.c_str(), 0, rgb.data(), 3 * width, nullptr)) {
    std::remove(tmp.c_str());
    throw std::runtime_error(fmt::format("cannot write {}: {}", path, image.message));
  }
  MoveIntoPlace(tmp, path);
}

}  // namespace mjstepper::tools
