// Writing rendered frames: single PNG files, PNG sequences (--frames DIR) and H.264 MP4 movies
// through the `ffmpeg` program.
//
// No partial output: every writer works on a temporary name in the destination directory and
// renames it into place only when it finishes successfully. A writer destroyed without Finish(),
// or whose encoder fails, removes its temporary output.
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <string>
#include <vector>

#include "render/image.h"

namespace fesim::render {

/// Encodes an image as an 8-bit RGB PNG (zlib level 3, filter None). Deterministic.
/// Throws std::invalid_argument on an empty image or a buffer of the wrong size.
std::vector<std::uint8_t> EncodePng(const Image& image);

/// Writes EncodePng(image) to path atomically (temporary file + rename). Throws
/// std::runtime_error naming the path on failure; never leaves a partial file.
void WritePng(const std::string& path, const Image& image);

/// Writes frames as DIR/frame_000000.png, frame_000001.png, … into DIR.tmp, renamed to DIR by
/// Finish(). DIR must not exist or be an empty directory; a stale DIR.tmp is removed.
class PngSequenceWriter {
 public:
  /// Throws std::runtime_error with a one-line message when DIR exists and is not empty, or
  /// DIR.tmp cannot be created.
  explicit PngSequenceWriter(const std::string& dir);
  ~PngSequenceWriter();  ///< Without Finish(): removes DIR.tmp.
  PngSequenceWriter(const PngSequenceWriter&) = delete;
  PngSequenceWriter& operator=(const PngSequenceWriter&) = delete;

  /// Writes the next frame; all frames must have the size of the first. Throws on error (the
  /// writer is then failed: nothing will be left behind).
  void AddFrame(const Image& image);
  /// Renames DIR.tmp to DIR. Throws std::runtime_error when no frame was written or on failure.
  void Finish();

  int frame_count() const { return frames_; }

 private:
  void Abort() noexcept;

  std::string dir_;
  std::string tmp_dir_;
  int frames_ = 0;
  int width_ = 0;
  int height_ = 0;
  bool open_ = false;
};

/// Encoder settings for Mp4Writer.
struct Mp4Options {
  std::string ffmpeg = "ffmpeg";    ///< program, looked up in PATH when it has no '/'.
  std::string codec = "libx264";    ///< ffmpeg video encoder.
  std::string preset = "veryfast";  ///< x264 preset (speed/size trade-off; empty: ffmpeg's).
  int crf = 20;                     ///< x264 constant rate factor, 0–51 (lower: better).
};

/// Pipes raw RGB frames to `ffmpeg -f rawvideo -pix_fmt rgb24 -s WxH -r FPS -i - -c:v libx264
/// -pix_fmt yuv420p` writing an MP4 to a temporary file next to the destination, renamed on a
/// successful Finish().
class Mp4Writer {
 public:
  /// Starts ffmpeg. width and height are pixels, even (yuv420p), 2–kMaxImageSidePx; fps is frames
  /// per second, in (0, 1000]. Throws std::runtime_error with a one-line message on bad
  /// arguments, an unwritable destination directory or when ffmpeg cannot be started; nothing is
  /// left behind.
  Mp4Writer(const std::string& path, int width, int height, double fps,
            const Mp4Options& options = {});
  ~Mp4Writer();  ///< Without Finish(): stops ffmpeg and removes the temporary file.
  Mp4Writer(const Mp4Writer&) = delete;
  Mp4Writer& operator=(const Mp4Writer&) = delete;

  /// Sends one frame (must be width × height). Throws std::runtime_error (with ffmpeg's message)
  /// if ffmpeg has failed; the writer is then failed and its temporary file removed.
  void AddFrame(const Image& image);
  /// Closes the stream, waits for ffmpeg and renames the file into place. Throws
  /// std::runtime_error with ffmpeg's message if it failed or no frame was written; no file
  /// remains in that case.
  void Finish();

  int frame_count() const { return frames_; }

 private:
  void Abort() noexcept;
  std::string FfmpegError() const;  ///< last lines of ffmpeg's stderr, one line.

  std::string path_;
  std::string tmp_path_;
  int tmp_slot_ = -1;  ///< RegisterTempFile slot of tmp_path_ (signal cleanup).
  int width_ = 0;
  int height_ = 0;
  int frames_ = 0;
  int pipe_fd_ = -1;  ///< our end of ffmpeg's stdin (a socket, so writes never raise SIGPIPE).
  int log_fd_ = -1;   ///< ffmpeg's stderr (unlinked temporary file).
  pid_t pid_ = -1;    ///< the ffmpeg child process.
};

}  // namespace fesim::render
