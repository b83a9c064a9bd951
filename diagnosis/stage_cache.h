// The resume cache of `fesim diagnose`, typed at the edge: a stage's result is a struct with
// `Json ToJson(const T&)` and `void FromJson(const Json&, T*)` overloads (declared next to the
// struct), stored in a ResultCache (base/result_cache.h) under the caller's inputs, the
// settings' key text and the stage's own key parts. A computed result goes through its JSON text
// as well (FromJson(Parse(Dump(ToJson(x))))), so a fresh and a resumed run continue from the same
// numbers.
#pragma once

#include <Eigen/Dense>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

#include "base/json.h"
#include "base/result_cache.h"
#include "diagnosis/extended_model.h"

namespace fesim::diagnosis {

/// Member `key` of object `j`; std::runtime_error naming it when absent.
const Json& Member(const Json& j, const std::string& key);

/// Key text of a parameter vector ("x=v0,v1,…", shortest round-trip digits).
std::string VectorKey(const std::string& name, const Eigen::VectorXd& x);

Json ToJson(const Eigen::VectorXd& v);
void FromJson(const Json& j, Eigen::VectorXd* v);
Json ToJson(const Eigen::MatrixXd& m);
void FromJson(const Json& j, Eigen::MatrixXd* m);
/// A fit without its Jacobian, residual and predictions.
Json ToJson(const FitResult& f);
void FromJson(const Json& j, FitResult* f);
Json ToJson(const std::vector<Trial>& trials);
void FromJson(const Json& j, std::vector<Trial>* trials);

class StageCache {
 public:
  /// `cache` may be null (nothing stored, everything computed); `prefix` heads every key;
  /// *cached counts the stages read back.
  StageCache(ResultCache* cache, std::vector<std::string> prefix, int* cached)
      : cache_(cache), prefix_(std::move(prefix)), cached_(cached) {}

  /// The stage's cached JSON, or compute(), stored, and returned through its text.
  Json GetJson(const std::vector<std::string>& stage, const std::function<Json()>& compute) const;

  template <typename T>
  T Get(const std::vector<std::string>& stage, const std::function<T()>& compute) const {
    const Json j = GetJson(stage, [&] { return ToJson(compute()); });
    T value;
    FromJson(j, &value);
    return value;
  }

 private:
  ResultCache* cache_;
  std::vector<std::string> prefix_;
  int* cached_;
  mutable std::mutex mutex_;
};

}  // namespace fesim::diagnosis
