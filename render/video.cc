#include "render/video.h"

#include <fcntl.h>
#include <signal.h>  // NOLINT(modernize-deprecated-headers): POSIX kill(), not in <csignal>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include <zlib.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <system_error>

#include "base/trial.h"
#include "render/renderer.h"

// POSIX: the application declares environ (glibc declares it only under _GNU_SOURCE).
extern char** environ;  // NOLINT(readability-redundant-declaration): see above

namespace fesim::render {
namespace {

namespace fs = std::filesystem;

/// zlib level for PNG frames: 3 is ~3× faster than the default 6 on 1280×720 frames, with files
/// ~1.5× larger (measured on the demo arm: 10 ms / 50 kB vs 33 ms / 32 kB).
constexpr int kPngCompressionLevel = 3;

void PutU32(std::vector<std::uint8_t>* out, std::uint32_t v) {
  out->push_back(static_cast<std::uint8_t>(v >> 24));
  out->push_back(static_cast<std::uint8_t>(v >> 16));
  out->push_back(static_cast<std::uint8_t>(v >> 8));
  out->push_back(static_cast<std::uint8_t>(v));
}

/// Appends a PNG chunk: length, type, data, CRC-32 of type + data.
void PutChunk(std::vector<std::uint8_t>* out, const char type[4], const std::uint8_t* data,
              std::size_t size) {
  PutU32(out, static_cast<std::uint32_t>(size));
  const std::size_t start = out->size();
  out->insert(out->end(), type, type + 4);
  if (size > 0) out->insert(out->end(), data, data + size);
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), out->data() + start, static_cast<uInt>(4 + size));
  PutU32(out, static_cast<std::uint32_t>(crc));
}

std::string ErrnoText(int error) { return std::generic_category().message(error); }

/// Writes all bytes to fd; returns 0 or the errno.
int WriteAll(int fd, const std::uint8_t* data, std::size_t size) {
  while (size > 0) {
    const ssize_t n = ::write(fd, data, size);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  return 0;
}

std::string ParentDir(const std::string& path) {
  const fs::path parent = fs::path(path).parent_path();
  return parent.empty() ? std::string(".") : parent.string();
}

void CheckImage(const Image& image) {
  if (image.width <= 0 || image.height <= 0) {
    throw std::invalid_argument("png: image is empty (" + std::to_string(image.width) + "x" +
                                std::to_string(image.height) + ")");
  }
  if (image.rgb.size() != 3 * static_cast<std::size_t>(image.width) * image.height) {
    throw std::invalid_argument("png: image buffer has " + std::to_string(image.rgb.size()) +
                                " bytes, expected 3*width*height");
  }
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// PNG

std::vector<std::uint8_t> EncodePng(const Image& image) {
  CheckImage(image);
  const std::size_t row = 3 * static_cast<std::size_t>(image.width);
  // Filter type 0 (None) on every row: rendered frames are mostly flat colour, where deflate
  // alone does as well as the Sub/Up filters, and faster.
  std::vector<std::uint8_t> filtered((row + 1) * image.height);
  for (int y = 0; y < image.height; ++y) {
    std::uint8_t* dst = &filtered[(row + 1) * y];
    dst[0] = 0;
    std::memcpy(dst + 1, &image.rgb[row * y], row);
  }
  uLongf compressed_size = compressBound(static_cast<uLong>(filtered.size()));
  std::vector<std::uint8_t> compressed(compressed_size);
  if (compress2(compressed.data(), &compressed_size, filtered.data(),
                static_cast<uLong>(filtered.size()), kPngCompressionLevel) != Z_OK) {
    throw std::runtime_error("png: zlib compression failed");
  }

  std::vector<std::uint8_t> out = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  std::vector<std::uint8_t> header;
  PutU32(&header, static_cast<std::uint32_t>(image.width));
  PutU32(&header, static_cast<std::uint32_t>(image.height));
  // bit depth 8, colour type 2 (RGB), deflate, adaptive filtering, no interlace.
  header.insert(header.end(), {8, 2, 0, 0, 0});
  PutChunk(&out, "IHDR", header.data(), header.size());
  PutChunk(&out, "IDAT", compressed.data(), compressed_size);
  PutChunk(&out, "IEND", nullptr, 0);
  return out;
}

void WritePng(const std::string& path, const Image& image) {
  const std::vector<std::uint8_t> png = EncodePng(image);
  std::string tmp = ParentDir(path) + "/." + fs::path(path).filename().string() + ".tmp-XXXXXX";
  const int fd = ::mkstemp(tmp.data());
  if (fd < 0) {
    throw std::runtime_error("png: cannot create a temporary file for " + path + ": " +
                             ErrnoText(errno));
  }
  const int slot = RegisterTempFile(tmp);
  int error = WriteAll(fd, png.data(), png.size());
  if (::close(fd) != 0 && error == 0) error = errno;
  // mkstemp creates 0600; give the file the usual permissions.
  if (error == 0) ::chmod(tmp.c_str(), 0644);
  if (error == 0 && std::rename(tmp.c_str(), path.c_str()) != 0) error = errno;
  UnregisterTempFile(slot);
  if (error != 0) {
    ::unlink(tmp.c_str());
    throw std::runtime_error("png: cannot write " + path + ": " + ErrnoText(error));
  }
}

// ---------------------------------------------------------------------------------------------
// PNG sequence

PngSequenceWriter::PngSequenceWriter(const std::string& dir) : dir_(dir) {
  while (dir_.size() > 1 && dir_.back() == '/') dir_.pop_back();
  if (dir_.empty()) throw std::runtime_error("frames: directory name is empty");
  tmp_dir_ = dir_ + ".tmp";
  std::error_code ec;
  if (fs::exists(dir_, ec)) {
    if (!fs::is_directory(dir_, ec) || !fs::is_empty(dir_, ec)) {
      throw std::runtime_error("frames: " + dir_ + " exists and is not an empty directory");
    }
  }
  fs::remove_all(tmp_dir_, ec);  // stale output of an interrupted run
  if (!fs::create_directory(tmp_dir_, ec) || ec) {
    throw std::runtime_error("frames: cannot create " + tmp_dir_ + ": " +
                             (ec ? ec.message() : std::string("already exists")));
  }
  open_ = true;
}

PngSequenceWriter::~PngSequenceWriter() { Abort(); }

void PngSequenceWriter::Abort() noexcept {
  if (!open_) return;
  std::error_code ec;
  fs::remove_all(tmp_dir_, ec);
  open_ = false;
}

void PngSequenceWriter::AddFrame(const Image& image) {
  if (!open_) throw std::runtime_error("frames: writer for " + dir_ + " is finished or failed");
  if (frames_ == 0) {
    width_ = image.width;
    height_ = image.height;
  } else if (image.width != width_ || image.height != height_) {
    Abort();
    throw std::runtime_error("frames: frame " + std::to_string(frames_) + " is " +
                             std::to_string(image.width) + "x" + std::to_string(image.height) +
                             ", expected " + std::to_string(width_) + "x" +
                             std::to_string(height_));
  }
  char name[32];
  std::snprintf(name, sizeof name, "/frame_%06d.png", frames_);
  try {
    WritePng(tmp_dir_ + name, image);
  } catch (...) {
    Abort();
    throw;
  }
  ++frames_;
}

void PngSequenceWriter::Finish() {
  if (!open_) throw std::runtime_error("frames: writer for " + dir_ + " is finished or failed");
  if (frames_ == 0) {
    Abort();
    throw std::runtime_error("frames: no frame written to " + dir_);
  }
  std::error_code ec;
  if (fs::exists(dir_, ec)) fs::remove(dir_, ec);  // empty (checked at construction)
  if (std::rename(tmp_dir_.c_str(), dir_.c_str()) != 0) {
    const int error = errno;
    Abort();
    throw std::runtime_error("frames: cannot rename " + tmp_dir_ + " to " + dir_ + ": " +
                             ErrnoText(error));
  }
  open_ = false;
}

// ---------------------------------------------------------------------------------------------
// MP4 through ffmpeg

Mp4Writer::Mp4Writer(const std::string& path, int width, int height, double fps,
                     const Mp4Options& options)
    : path_(path), width_(width), height_(height) {
  const std::string what = "mp4: " + path + ": ";
  if (path.empty()) throw std::runtime_error("mp4: output path is empty");
  if (width < 2 || height < 2 || width > kMaxImageSidePx || height > kMaxImageSidePx ||
      width % 2 != 0 || height % 2 != 0) {
    throw std::runtime_error(what + "frame size " + std::to_string(width) + "x" +
                             std::to_string(height) + " is invalid (even sides, 2-" +
                             std::to_string(kMaxImageSidePx) + " pixels, for yuv420p)");
  }
  if (!(fps > 0 && fps <= 1000)) {
    throw std::runtime_error(what + "frame rate must be in (0, 1000] frames per second");
  }
  if (options.crf < 0 || options.crf > 51) throw std::runtime_error(what + "crf must be 0-51");
  const std::string dir = ParentDir(path);
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw std::runtime_error(what + "directory " + dir + " does not exist");
  }

  // ffmpeg's stderr goes to an unlinked temporary file, read back for error messages.
  std::string log = (fs::temp_directory_path(ec) / "fesim-ffmpeg-XXXXXX").string();
  log_fd_ = ::mkostemp(log.data(), O_CLOEXEC);
  if (log_fd_ < 0) throw std::runtime_error(what + "cannot create a log file: " + ErrnoText(errno));
  ::unlink(log.c_str());

  tmp_path_ = dir + "/." + fs::path(path).filename().string() + ".tmp-XXXXXX.mp4";
  const int tmp_fd = ::mkostemps(tmp_path_.data(), 4, O_CLOEXEC);
  if (tmp_fd < 0) {
    const int error = errno;
    ::close(log_fd_);
    log_fd_ = -1;
    throw std::runtime_error(what + "cannot create a temporary file in " + dir + ": " +
                             ErrnoText(error));
  }
  ::close(tmp_fd);
  ::chmod(tmp_path_.c_str(), 0644);
  tmp_slot_ = RegisterTempFile(tmp_path_);  // removed by the CLI's SIGINT/SIGTERM handler

  char fps_text[32];
  std::snprintf(fps_text, sizeof fps_text, "%.9g", fps);
  std::vector<std::string> args = {options.ffmpeg,
                                   "-hide_banner",
                                   "-loglevel",
                                   "error",
                                   "-y",
                                   "-f",
                                   "rawvideo",
                                   "-pix_fmt",
                                   "rgb24",
                                   "-s",
                                   std::to_string(width) + "x" + std::to_string(height),
                                   "-r",
                                   fps_text,
                                   "-i",
                                   "-",
                                   "-an",
                                   "-c:v",
                                   options.codec};
  if (options.codec.rfind("libx26", 0) == 0) {
    if (!options.preset.empty()) args.insert(args.end(), {"-preset", options.preset});
    args.insert(args.end(), {"-crf", std::to_string(options.crf)});
  }
  args.insert(args.end(), {"-pix_fmt", "yuv420p", "-f", "mp4", tmp_path_});
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);

  // A socket instead of a pipe: send(MSG_NOSIGNAL) reports a dead ffmpeg as EPIPE without
  // raising SIGPIPE in this process.
  int fds[2];
  if (::socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, fds) != 0) {
    const int error = errno;
    Abort();
    throw std::runtime_error(what + "socketpair failed: " + ErrnoText(error));
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDIN_FILENO);
  posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, log_fd_, STDERR_FILENO);
  pid_t pid = -1;
  const int spawn_error =
      options.ffmpeg.find('/') == std::string::npos
          ? ::posix_spawnp(&pid, options.ffmpeg.c_str(), &actions, nullptr, argv.data(), environ)
          : ::posix_spawn(&pid, options.ffmpeg.c_str(), &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  pipe_fd_ = fds[0];
  if (spawn_error != 0) {
    Abort();
    throw std::runtime_error(what + "cannot start '" + options.ffmpeg +
                             "': " + ErrnoText(spawn_error) + " (install the ffmpeg package)");
  }
  pid_ = pid;
}

Mp4Writer::~Mp4Writer() { Abort(); }

void Mp4Writer::Abort() noexcept {
  if (pipe_fd_ >= 0) {
    ::close(pipe_fd_);
    pipe_fd_ = -1;
  }
  if (pid_ > 0) {
    ::kill(pid_, SIGKILL);  // our own child; its output is being discarded
    int status = 0;
    while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
  }
  if (!tmp_path_.empty()) {
    ::unlink(tmp_path_.c_str());
    tmp_path_.clear();
  }
  UnregisterTempFile(tmp_slot_);
  tmp_slot_ = -1;
  if (log_fd_ >= 0) {
    ::close(log_fd_);
    log_fd_ = -1;
  }
}

std::string Mp4Writer::FfmpegError() const {
  if (log_fd_ < 0) return "";
  std::string text;
  char buffer[4096];
  ::lseek(log_fd_, 0, SEEK_SET);
  ssize_t n;
  while ((n = ::read(log_fd_, buffer, sizeof buffer)) > 0) text.append(buffer, n);
  // One line: the last few non-empty lines joined with "; ".
  std::vector<std::string> lines;
  std::size_t start = 0;
  while (start < text.size()) {
    std::size_t end = text.find('\n', start);
    if (end == std::string::npos) end = text.size();
    std::string line = text.substr(start, end - start);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
    if (!line.empty()) lines.push_back(line);
    start = end + 1;
  }
  std::string out;
  for (std::size_t i = lines.size() > 3 ? lines.size() - 3 : 0; i < lines.size(); ++i) {
    if (!out.empty()) out += "; ";
    out += lines[i];
  }
  if (out.size() > 400) out = out.substr(out.size() - 400);
  return out.empty() ? "no message" : out;
}

void Mp4Writer::AddFrame(const Image& image) {
  if (pid_ <= 0 || pipe_fd_ < 0) {
    throw std::runtime_error("mp4: " + path_ + ": writer is finished or failed");
  }
  if (image.width != width_ || image.height != height_ ||
      image.rgb.size() != 3 * static_cast<std::size_t>(width_) * height_) {
    Abort();
    throw std::runtime_error("mp4: " + path_ + ": frame " + std::to_string(frames_) + " is " +
                             std::to_string(image.width) + "x" + std::to_string(image.height) +
                             ", expected " + std::to_string(width_) + "x" +
                             std::to_string(height_));
  }
  const std::uint8_t* data = image.rgb.data();
  std::size_t size = image.rgb.size();
  while (size > 0) {
    const ssize_t n = ::send(pipe_fd_, data, size, MSG_NOSIGNAL);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int error = errno;
      ::close(pipe_fd_);
      pipe_fd_ = -1;
      int status = 0;
      while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
      }
      pid_ = -1;
      const std::string message = FfmpegError();
      Abort();
      throw std::runtime_error("mp4: " + path_ + ": ffmpeg stopped reading frames (" +
                               ErrnoText(error) + "): " + message);
    }
    data += n;
    size -= static_cast<std::size_t>(n);
  }
  ++frames_;
}

void Mp4Writer::Finish() {
  if (pid_ <= 0) throw std::runtime_error("mp4: " + path_ + ": writer is finished or failed");
  if (frames_ == 0) {
    Abort();
    throw std::runtime_error("mp4: " + path_ + ": no frame written");
  }
  ::close(pipe_fd_);  // end of input: ffmpeg flushes the encoder and writes the MP4 index
  pipe_fd_ = -1;
  int status = 0;
  while (::waitpid(pid_, &status, 0) < 0 && errno == EINTR) {
  }
  pid_ = -1;
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    const std::string how = WIFEXITED(status) ? "exit status " + std::to_string(WEXITSTATUS(status))
                                              : "signal " + std::to_string(WTERMSIG(status));
    const std::string message = FfmpegError();
    Abort();
    throw std::runtime_error("mp4: " + path_ + ": ffmpeg failed (" + how + "): " + message);
  }
  std::error_code ec;
  if (fs::file_size(tmp_path_, ec) == 0 || ec) {
    Abort();
    throw std::runtime_error("mp4: " + path_ + ": ffmpeg wrote no output");
  }
  if (std::rename(tmp_path_.c_str(), path_.c_str()) != 0) {
    const int error = errno;
    Abort();
    throw std::runtime_error("mp4: cannot rename the temporary file to " + path_ + ": " +
                             ErrnoText(error));
  }
  tmp_path_.clear();
  Abort();  // closes the log
}

}  // namespace fesim::render
