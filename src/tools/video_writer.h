// Frames out: an MP4 through the Debian `ffmpeg` program (a pipe of raw RGB frames into libx264),
// and PNG files through libpng. Both write to a temporary name and rename when complete.
#ifndef MJSTEPPER_TOOLS_VIDEO_WRITER_H_
#define MJSTEPPER_TOOLS_VIDEO_WRITER_H_

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

namespace mjstepper::tools {

class VideoWriter {
 public:
  /// Starts ffmpeg writing `path`.tmp.mp4; throws std::runtime_error when it cannot start.
  VideoWriter(std::string path, int width, int height, double fps);
  ~VideoWriter();  ///< without Finish: stops ffmpeg and removes the temporary file
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// One frame, RGB rows from the top, width·height·3 bytes.
  void Write(const std::vector<std::uint8_t>& rgb);
  /// Waits for ffmpeg and renames into place; throws std::runtime_error if ffmpeg failed.
  void Finish();
  long frames() const { return frames_; }

 private:
  std::string path_, tmp_path_;
  int width_, height_;
  std::FILE* pipe_ = nullptr;
  long frames_ = 0;
};

/// Writes an RGB image (rows from the top) as PNG, via a temporary file; throws on error.
void WritePng(const std::string& path, const std::vector<std::uint8_t>& rgb, int width, int height);

}  // namespace mjstepper::tools

#endif  // MJSTEPPER_TOOLS_VIDEO_WRITER_H_
