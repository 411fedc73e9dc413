// Frames out: an MP4 through the Debian `ffmpeg` program (raw RGB frames on its standard input,
// libx264 out), started without a shell, and PNG files through libpng. Both are OutputFiles
// (output_file.h): written to an exclusive temporary beside the target, renamed when complete.
#ifndef MJSTEPPER_TOOLS_VIDEO_WRITER_H_
#define MJSTEPPER_TOOLS_VIDEO_WRITER_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "output_file.h"
#include "subprocess.h"

namespace mjstepper::tools {

/// The ffmpeg program on PATH; throws naming it and the Debian package when it is missing.
std::string FfmpegProgram();

class VideoWriter {
 public:
  /// Starts ffmpeg writing `path`'s temporary; throws std::runtime_error when it cannot start.
  VideoWriter(std::string path, int width, int height, double fps);
  ~VideoWriter() = default;  ///< without Finish: ffmpeg is stopped, the temporary removed
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// One frame, RGB rows from the top, width·height·3 bytes.
  void Write(const std::vector<std::uint8_t>& rgb);
  /// Waits for ffmpeg and renames into place; throws std::runtime_error if ffmpeg failed.
  void Finish();
  long frames() const { return frames_; }

 private:
  OutputFile output_;
  std::optional<Subprocess> ffmpeg_;  // after output_: stopped before the temporary is removed
  long frames_ = 0;
};

/// Writes an RGB image (rows from the top) as PNG, via a temporary file; throws on error.
void WritePng(const std::string& path, const std::vector<std::uint8_t>& rgb, int width, int height);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_VIDEO_WRITER_H_
