#include "render/video.h"

#include <gtest/gtest.h>
#include <stdlib.h>  // NOLINT(modernize-deprecated-headers): POSIX mkdtemp(), not in <cstdlib>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "tests/testing/process.h"

namespace fesim::render {
namespace {

using ::fesim::test_util::FindProgram;
using ::fesim::test_util::RunCommand;

namespace fs = std::filesystem;

constexpr int kFrames = 12;        ///< frames in the test movie.
constexpr int kMovieWidth = 320;   ///< pixels.
constexpr int kMovieHeight = 240;  ///< pixels.
constexpr int kMovieFps = 25;      ///< frames per second.

/// A fresh empty directory, removed with everything in it at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::string pattern = (fs::temp_directory_path() / "fesim_video_test_XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = pattern;
  }
  ~TempDir() {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }
  std::vector<std::string> Entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(path_)) names.push_back(e.path().filename());
    std::sort(names.begin(), names.end());
    return names;
  }

 private:
  fs::path path_;
};

/// A test pattern that changes with the frame index.
Image Pattern(int width, int height, int index) {
  Image image = MakeImage(width, height, Rgba{0.2f, 0.3f, 0.4f, 1});
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x) {
      std::uint8_t* p = image.At(x, y);
      p[0] = static_cast<std::uint8_t>(x * 255 / width);
      p[1] = static_cast<std::uint8_t>(y * 255 / height);
      p[2] = static_cast<std::uint8_t>((x + y + 7 * index) & 0xFF);
    }
  }
  return image;
}

std::uint32_t ReadU32(const std::vector<std::uint8_t>& b, std::size_t at) {
  return (std::uint32_t{b[at]} << 24) | (std::uint32_t{b[at + 1]} << 16) |
         (std::uint32_t{b[at + 2]} << 8) | b[at + 3];
}

/// Minimal PNG reader for the encoder's own output (one IDAT, RGB 8-bit, filters None/Sub);
/// checks every chunk CRC.
Image DecodeOwnPng(const std::vector<std::uint8_t>& png) {
  Image image;
  std::vector<std::uint8_t> idat;
  std::size_t at = 8;
  while (at + 12 <= png.size()) {
    const std::uint32_t length = ReadU32(png, at);
    const std::string type(png.begin() + at + 4, png.begin() + at + 8);
    const uLong crc = crc32(crc32(0, Z_NULL, 0), &png[at + 4], 4 + length);
    EXPECT_EQ(crc, ReadU32(png, at + 8 + length)) << type;
    if (type == "IHDR") {
      image.width = static_cast<int>(ReadU32(png, at + 8));
      image.height = static_cast<int>(ReadU32(png, at + 12));
    } else if (type == "IDAT") {
      idat.insert(idat.end(), png.begin() + at + 8, png.begin() + at + 8 + length);
    }
    at += 12 + length;
  }
  const std::size_t row = 3 * static_cast<std::size_t>(image.width);
  std::vector<std::uint8_t> raw((row + 1) * image.height);
  uLongf raw_size = raw.size();
  EXPECT_EQ(uncompress(raw.data(), &raw_size, idat.data(), idat.size()), Z_OK);
  image.rgb.resize(row * image.height);
  for (int y = 0; y < image.height; ++y) {
    const std::uint8_t filter = raw[(row + 1) * y];
    for (std::size_t i = 0; i < row; ++i) {
      std::uint8_t v = raw[(row + 1) * y + 1 + i];
      if (filter == 1 && i >= 3) v = static_cast<std::uint8_t>(v + image.rgb[row * y + i - 3]);
      image.rgb[row * y + i] = v;
    }
  }
  return image;
}

std::vector<std::uint8_t> ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(PngTest, EncodesWhatItWasGiven) {
  const Image image = Pattern(37, 11, 3);
  const std::vector<std::uint8_t> png = EncodePng(image);
  ASSERT_GT(png.size(), 8u);
  EXPECT_EQ(std::string(png.begin() + 1, png.begin() + 4), "PNG");
  const Image decoded = DecodeOwnPng(png);
  EXPECT_EQ(decoded.width, 37);
  EXPECT_EQ(decoded.height, 11);
  EXPECT_TRUE(decoded.rgb == image.rgb);
  EXPECT_TRUE(EncodePng(image) == png);  // deterministic
  EXPECT_THROW(EncodePng(Image{}), std::invalid_argument);
}

TEST(PngTest, FfmpegDecodesTheSamePixels) {
  const std::string ffmpeg = FindProgram("ffmpeg");
  ASSERT_FALSE(ffmpeg.empty()) << "ffmpeg not found in PATH (apt-get install ffmpeg)";
  TempDir dir;
  const Image image = Pattern(64, 48, 1);
  const fs::path path = dir.path() / "frame.png";
  WritePng(path.string(), image);
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"frame.png"});  // no temporary left
  const std::string raw = RunCommand(ffmpeg + " -v error -i '" + path.string() +
                                     "' -f rawvideo -pix_fmt rgb24 - 2>/dev/null");
  EXPECT_TRUE(std::vector<std::uint8_t>(raw.begin(), raw.end()) == image.rgb);
}

TEST(PngTest, UnwritablePathThrowsAndLeavesNothing) {
  TempDir dir;
  EXPECT_THROW(WritePng((dir.path() / "missing" / "x.png").string(), Pattern(4, 4, 0)),
               std::runtime_error);
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(PngSequenceWriterTest, WritesNumberedFramesAndRenamesOnFinish) {
  TempDir dir;
  const fs::path frames = dir.path() / "frames";
  {
    PngSequenceWriter writer(frames.string());
    for (int i = 0; i < 3; ++i) writer.AddFrame(Pattern(16, 8, i));
    EXPECT_FALSE(fs::exists(frames));  // only DIR.tmp until Finish()
    writer.Finish();
    EXPECT_EQ(writer.frame_count(), 3);
  }
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"frames"});
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(frames)) names.push_back(e.path().filename());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names,
            (std::vector<std::string>{"frame_000000.png", "frame_000001.png", "frame_000002.png"}));
  EXPECT_TRUE(DecodeOwnPng(ReadFile(frames / "frame_000002.png")).rgb == Pattern(16, 8, 2).rgb);
}

TEST(PngSequenceWriterTest, NoFinishOrBadFrameLeavesNothing) {
  TempDir dir;
  const std::string frames = (dir.path() / "frames").string();
  {
    PngSequenceWriter writer(frames);
    writer.AddFrame(Pattern(16, 8, 0));
  }
  EXPECT_TRUE(dir.Entries().empty());
  {
    PngSequenceWriter writer(frames);
    writer.AddFrame(Pattern(16, 8, 0));
    EXPECT_THROW(writer.AddFrame(Pattern(8, 8, 1)), std::runtime_error);
    EXPECT_THROW(writer.Finish(), std::runtime_error);
  }
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(PngSequenceWriterTest, RefusesANonEmptyDirectory) {
  TempDir dir;
  fs::create_directory(dir.path() / "frames");
  std::ofstream(dir.path() / "frames" / "keep.txt") << "x";
  EXPECT_THROW(PngSequenceWriter((dir.path() / "frames").string()), std::runtime_error);
  EXPECT_TRUE(fs::exists(dir.path() / "frames" / "keep.txt"));
}

TEST(Mp4WriterTest, MovieDecodesWithRequestedSizeRateAndFrameCount) {
  const std::string ffprobe = FindProgram("ffprobe");
  ASSERT_FALSE(ffprobe.empty()) << "ffprobe not found in PATH (apt-get install ffmpeg)";
  TempDir dir;
  const fs::path movie = dir.path() / "movie.mp4";
  {
    Mp4Writer writer(movie.string(), kMovieWidth, kMovieHeight, kMovieFps);
    for (int i = 0; i < kFrames; ++i) writer.AddFrame(Pattern(kMovieWidth, kMovieHeight, i));
    EXPECT_EQ(writer.frame_count(), kFrames);
    writer.Finish();
  }
  EXPECT_EQ(dir.Entries(), std::vector<std::string>{"movie.mp4"});  // no temporary left
  const std::string probe =
      RunCommand(ffprobe + " -v error -select_streams v:0 -count_frames -show_entries " +
                 "stream=codec_name,width,height,r_frame_rate,nb_read_frames -of " +
                 "default=noprint_wrappers=1 '" + movie.string() + "'");
  EXPECT_NE(probe.find("codec_name=h264"), std::string::npos) << probe;
  EXPECT_NE(probe.find("width=" + std::to_string(kMovieWidth) + "\n"), std::string::npos) << probe;
  EXPECT_NE(probe.find("height=" + std::to_string(kMovieHeight) + "\n"), std::string::npos)
      << probe;
  EXPECT_NE(probe.find("r_frame_rate=" + std::to_string(kMovieFps) + "/1"), std::string::npos)
      << probe;
  EXPECT_NE(probe.find("nb_read_frames=" + std::to_string(kFrames) + "\n"), std::string::npos)
      << probe;
}

TEST(Mp4WriterTest, BadSizeOrRateIsAClearErrorAndLeavesNothing) {
  TempDir dir;
  const std::string movie = (dir.path() / "movie.mp4").string();
  try {
    Mp4Writer writer(movie, 0, 240, 25);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("0x240"), std::string::npos) << e.what();
  }
  EXPECT_THROW(Mp4Writer(movie, 321, 240, 25), std::runtime_error);  // odd: not yuv420p
  EXPECT_THROW(Mp4Writer(movie, 320, 240, 0), std::runtime_error);
  EXPECT_THROW(Mp4Writer((dir.path() / "no" / "m.mp4").string(), 320, 240, 25), std::runtime_error);
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(Mp4WriterTest, FailedEncodeLeavesNoFile) {
  TempDir dir;
  const std::string movie = (dir.path() / "movie.mp4").string();
  Mp4Options options;
  options.codec = "no_such_encoder";
  try {
    Mp4Writer writer(movie, 64, 48, 25, options);
    for (int i = 0; i < 3; ++i) writer.AddFrame(Pattern(64, 48, i));
    writer.Finish();
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("ffmpeg"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(Mp4WriterTest, MissingFfmpegProgramIsAClearError) {
  TempDir dir;
  Mp4Options options;
  options.ffmpeg = (dir.path() / "not-ffmpeg").string();
  try {
    Mp4Writer writer((dir.path() / "movie.mp4").string(), 64, 48, 25, options);
    FAIL() << "expected std::runtime_error";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("not-ffmpeg"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(dir.Entries().empty());
}

TEST(Mp4WriterTest, DestroyedWithoutFinishOrWrongFrameLeavesNoFile) {
  TempDir dir;
  const std::string movie = (dir.path() / "movie.mp4").string();
  {
    Mp4Writer writer(movie, 64, 48, 25);
    writer.AddFrame(Pattern(64, 48, 0));
  }
  EXPECT_TRUE(dir.Entries().empty());
  {
    Mp4Writer writer(movie, 64, 48, 25);
    EXPECT_THROW(writer.AddFrame(Pattern(32, 48, 0)), std::runtime_error);
    EXPECT_THROW(writer.Finish(), std::runtime_error);
  }
  {
    Mp4Writer writer(movie, 64, 48, 25);
    EXPECT_THROW(writer.Finish(), std::runtime_error);  // no frames
  }
  EXPECT_TRUE(dir.Entries().empty());
}

}  // namespace
}  // namespace fesim::render
