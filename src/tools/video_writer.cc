#include "video_writer.h"

#include <fmt/format.h>
#include <png.h>

#include <stdexcept>

namespace mjstepper::tools {

std::string FfmpegProgram() {
  return FindProgram("ffmpeg", "--render", "install it (Debian: apt-get install ffmpeg)");
}

VideoWriter::VideoWriter(std::string path, int width, int height, double fps)
    : output_(std::move(path)) {
  // No shell: one argument each. ffmpeg writes into our exclusive temporary through its own
  // descriptor 3 ("file:" so that no name is read as another protocol; -y because it exists);
  // yuv420p needs even sizes: the scale filter rounds down by at most one pixel.
  ffmpeg_.emplace(std::vector<std::string>{FfmpegProgram(),
                                           "-nostdin",
                                           "-loglevel",
                                           "error",
                                           "-y",
                                           "-f",
                                           "rawvideo",
                                           "-pix_fmt",
                                           "rgb24",
                                           "-s",
                                           fmt::format("{}x{}", width, height),
                                           "-r",
                                           fmt::format("{}", fps),
                                           "-i",
                                           "pipe:0",
                                           "-vf",
                                           "scale=trunc(iw/2)*2:trunc(ih/2)*2",
                                           "-c:v",
                                           "libx264",
                                           "-preset",
                                           "veryfast",
                                           "-crf",
                                           "26",
                                           "-pix_fmt",
                                           "yuv420p",
                                           "-movflags",
                                           "+faststart",
                                           "-f",
                                           "mp4",
                                           "file:/dev/fd/3"},
                  SpawnOptions{.pipe_stdin = true, .pass_fd = output_.fd()});
}

void VideoWriter::Write(const std::vector<std::uint8_t>& rgb) {
  if (!ffmpeg_ || !ffmpeg_->Write(rgb.data(), rgb.size())) {
    throw std::runtime_error(
        fmt::format("ffmpeg stopped taking frames for {} (it says why above)", output_.path()));
  }
  ++frames_;
}

void VideoWriter::Finish() {
  const int status = ffmpeg_->Wait();
  ffmpeg_.reset();
  if (status != 0) {
    throw std::runtime_error(
        fmt::format("ffmpeg failed writing {} (exit status {})", output_.path(), status));
  }
  output_.Commit();
}

void WritePng(const std::string& path, const std::vector<std::uint8_t>& rgb, int width,
              int height) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = width;
  image.height = height;
  image.format = PNG_FORMAT_RGB;
  image.flags = PNG_IMAGE_FLAG_FAST;  // lighter compression: frames are many and transient
  OutputFile out(path);
  if (!png_image_write_to_stdio(&image, out.stream(), 0, rgb.data(), 3 * width, nullptr)) {
    throw std::runtime_error(fmt::format("cannot write {}: {}", path, image.message));
  }
  out.Commit();
}

}  // namespace mjstepper::tools
