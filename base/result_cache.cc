#include "base/result_cache.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstdint>
#include <cstring>
#include <stdexcept>

namespace fesim {

std::vector<std::string> MakeDirs(const std::string& path) {
  std::vector<std::string> created;
  std::string cur;
  for (std::size_t i = 0; i <= path.size(); ++i) {
    if (i == path.size() || path[i] == '/') {
      if (!cur.empty()) {
        if (::mkdir(cur.c_str(), 0755) == 0) {
          created.push_back(cur);
        } else if (errno != EEXIST) {
          throw std::runtime_error(cur + ": cannot create directory: " + std::strerror(errno));
        }
      }
    }
    if (i < path.size()) cur.push_back(path[i]);
  }
  return created;
}

bool RegularFileExists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

Json WrittenFileRecord(const std::string& relative_path, const std::string& contents) {
  Json j = Json::Object();
  j.Set("path", relative_path)
      .Set("bytes", static_cast<double>(contents.size()))
      .Set("fnv1a64", Fnv1a64Hex(contents));
  return j;
}

std::string CheckWrittenFile(const std::string& dir, const Json& record) {
  const Json* path = record.Find("path");
  const Json* bytes = record.Find("bytes");
  const Json* hash = record.Find("fnv1a64");
  if (path == nullptr || !path->IsString() || bytes == nullptr || !bytes->IsNumber() ||
      hash == nullptr || !hash->IsString()) {
    throw std::runtime_error("written-file record: expected {path, bytes, fnv1a64}");
  }
  const std::string file = dir + "/" + path->AsString();
  struct stat st {};
  if (::stat(file.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return file + ": missing";
  const auto expected = static_cast<std::uint64_t>(bytes->AsNumber());
  if (static_cast<std::uint64_t>(st.st_size) != expected) {
    return file + ": " + std::to_string(st.st_size) + " bytes, " + std::to_string(expected) +
           " were written";
  }
  std::string contents;
  try {
    contents = ReadFile(file);
  } catch (const std::exception& e) {
    return e.what();
  }
  if (Fnv1a64Hex(contents) != hash->AsString()) {
    return file + ": contents differ from what was written (same size, other hash)";
  }
  return "";
}

ResultCache::ResultCache(std::string dir, std::string version, std::string layout)
    : dir_(std::move(dir)), version_(std::move(version)), layout_(std::move(layout)) {}

std::string ResultCache::Key(const std::vector<std::string>& parts) const {
  std::string all = version_ + "\n" + layout_;
  for (const auto& p : parts) all += "\n" + p;
  return Fnv1a64Hex(all);
}

std::string ResultCache::Path(const std::vector<std::string>& parts) const {
  return dir_ + "/" + Key(parts);
}

bool ResultCache::Load(const std::vector<std::string>& parts, Json* out) const {
  const std::string path = Path(parts) + ".json";
  if (!RegularFileExists(path)) return false;
  *out = Json::Parse(ReadFile(path), path);
  return true;
}

void ResultCache::Store(const std::vector<std::string>& parts, const Json& value) {
  const std::string text = value.Dump(0);
  std::lock_guard<std::mutex> lock(mutex_);
  const std::vector<std::string> created = MakeDirs(dir_);
  try {
    WriteFileAtomic(Path(parts) + ".json", text);
  } catch (...) {
    // The first write failed (e.g. disk full): leave no empty cache directory behind. rmdir
    // removes only empty directories, innermost first.
    for (auto it = created.rbegin(); it != created.rend(); ++it) ::rmdir(it->c_str());
    throw;
  }
}

Json TrialsToJson(const std::vector<Trial>& trials) {
  Json all = Json::Array();
  for (const Trial& t : trials) {
    Json meta = Json::Object();
    for (const auto& [k, v] : t.metadata) meta.Set(k, v);
    Json cols = Json::Object();
    for (std::size_t k = 0; k < t.names.size(); ++k) cols.Set(t.names[k], Json(t.columns[k]));
    Json j = Json::Object();
    j.Set("metadata", meta).Set("time", Json(t.time)).Set("columns", cols);
    all.Push(j);
  }
  return all;
}

std::vector<Trial> TrialsFromJson(const Json& all, const std::string& what) {
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error(what + ": cached trials: " + why);
  };
  if (!all.IsArray()) fail("expected an array");
  std::vector<Trial> out;
  for (const Json& j : all.Items()) {
    const Json* meta = j.Find("metadata");
    const Json* time = j.Find("time");
    const Json* cols = j.Find("columns");
    if (!meta || !meta->IsObject() || !time || !time->IsArray() || !cols || !cols->IsObject()) {
      fail("expected {metadata: {}, time: [], columns: {}}");
    }
    Trial t;
    for (std::size_t k = 0; k < meta->Keys().size(); ++k) {
      if (!meta->Items()[k].IsString()) fail("metadata " + meta->Keys()[k] + " is not text");
      t.metadata[meta->Keys()[k]] = meta->Items()[k].AsString();
    }
    for (const Json& v : time->Items()) t.time.push_back(v.AsNumber());
    for (std::size_t k = 0; k < cols->Keys().size(); ++k) {
      std::vector<double> c;
      for (const Json& v : cols->Items()[k].Items()) c.push_back(v.AsNumber());
      if (c.size() != t.time.size()) fail("column " + cols->Keys()[k] + " has the wrong length");
      t.AddColumn(cols->Keys()[k], std::move(c));
    }
    out.push_back(std::move(t));
  }
  return out;
}

std::string ExactNumberText(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return {buf, r.ptr};
}

}  // namespace fesim
