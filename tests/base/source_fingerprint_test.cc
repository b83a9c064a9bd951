// The build's identity in the result caches' keys (base/source_fingerprint.h,
// cmake/source_fingerprint.cmake).
#include "base/source_fingerprint.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "fesim/version.h"

namespace fesim {
namespace {

namespace fs = std::filesystem;

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The identity the generator script writes for the files listed in `list` under `root`.
std::string Fingerprint(const fs::path& list, const fs::path& root) {
  const fs::path out = fs::path(::testing::TempDir()) / "source_fingerprint_out.cc";
  fs::remove(out);
  const std::string command = std::string(FESIM_CMAKE_COMMAND) + " -DLIST=" + list.string() +
                              " -DROOT=" + root.string() +
                              " -DVERSION=9.8.7 -DOUT=" + out.string() + " -P " +
                              FESIM_SOURCE_DIR_PATH + "/cmake/source_fingerprint.cmake";
  EXPECT_EQ(std::system(command.c_str()), 0) << command;
  std::smatch m;
  const std::string text = ReadText(out);
  if (!std::regex_search(text, m, std::regex("return \"([^\"]*)\";"))) return "";
  return m[1];
}

TEST(SourceFingerprint, IsTheVersionAndSixteenHexDigits) {
  EXPECT_TRUE(std::regex_match(std::string(BuildIdentity()),
                               std::regex(std::string(FESIM_VERSION) + "\\+[0-9a-f]{16}")))
      << BuildIdentity();
}

TEST(SourceFingerprint, ChangesWhenASourceChangesAndOnlyThen) {
  const fs::path root = fs::path(::testing::TempDir()) / "source_fingerprint";
  fs::remove_all(root);
  fs::create_directories(root / "sim");
  WriteText(root / "sim/a.cc", "double k = 1.0;\n");
  WriteText(root / "sim/b.h", "#pragma once\n");
  const fs::path list = root / "list.txt";
  WriteText(list, (root / "sim/a.cc").string() + "\n" + (root / "sim/b.h").string() + "\n");
  const std::string first = Fingerprint(list, root);
  ASSERT_TRUE(std::regex_match(first, std::regex("9\\.8\\.7\\+[0-9a-f]{16}"))) << first;
  EXPECT_EQ(Fingerprint(list, root), first);  // nothing changed
  // The list's order is not the sources': the same files listed the other way round.
  WriteText(list, (root / "sim/b.h").string() + "\n" + (root / "sim/a.cc").string() + "\n");
  EXPECT_EQ(Fingerprint(list, root), first);
  WriteText(root / "sim/a.cc", "double k = 1.5;\n");  // a changed range, say
  const std::string edited = Fingerprint(list, root);
  EXPECT_NE(edited, first);
  WriteText(root / "sim/a.cc", "double k = 1.0;\n");
  EXPECT_EQ(Fingerprint(list, root), first);  // the content, not the time stamp
  // The same content under another name is other code (a file's role is its path).
  fs::rename(root / "sim/b.h", root / "sim/c.h");
  WriteText(list, (root / "sim/a.cc").string() + "\n" + (root / "sim/c.h").string() + "\n");
  EXPECT_NE(Fingerprint(list, root), first);
  // A file removed from the tree.
  WriteText(list, (root / "sim/a.cc").string() + "\n");
  EXPECT_NE(Fingerprint(list, root), first);
}

TEST(SourceFingerprint, ThisBuildIsFingerprintedFromItsSources) {
  // The list the configure step wrote, fingerprinted now: what this build's sources are.
  const std::string now = Fingerprint(FESIM_FINGERPRINT_LIST, FESIM_SOURCE_DIR_PATH);
  const std::string built = BuildIdentity();
  EXPECT_EQ(now.substr(now.find('+')), built.substr(built.find('+')))
      << "a source changed since this build: build again before testing";
}

}  // namespace
}  // namespace fesim
