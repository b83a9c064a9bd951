// Every value of the papers that `fesim benchmark`'s report quotes, in one table: the
// paper's file, its table (or text section), row, column, the number as printed and its unit.
// The sections look values up here; report.md prints each value's text as the paper prints it and
// results.json gives each section a "paper" block of its paper's entries.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "base/json.h"

namespace fesim::paper_benchmark {

/// The papers' files in papers/ (docs/papers.md gives their keys).
inline constexpr std::string_view kPaper000 = "000_0a6c0de9fc69df7c.txt";  ///< [Hand Hammerstein]
inline constexpr std::string_view kPaper001 = "001_50576a960b4d02ae.txt";  ///< [Copur 2016]
inline constexpr std::string_view kPaper002 = "002_78a57b74c57ee464.txt";  ///< [Le 2010]
inline constexpr std::string_view kPaper003 = "003_7182ceb830858ebb.txt";  ///< [Spagnol 2013]
inline constexpr std::string_view kPaper004 = "004_7ee2989736d21d4b.txt";  ///< [Schearer 2014]

/// One value a paper prints. `table` names the paper's table ("Table 3(a)") or, for a value
/// stated only in the prose, its section ("§7.3 text"); `row` and `column` are the paper's labels
/// (shortened); `source` says where the value stands when that is not plain from table, row and
/// column (empty otherwise).
struct PaperValue {
  std::string_view paper, table, row, column;
  std::string_view text;  ///< the number exactly as the paper prints it, e.g. "51.8".
  std::string_view unit;  ///< "%", "s", "deg", "N·m/deg", "N·m·s/deg"; "" when dimensionless.
  std::string_view source;
  double Value() const;  ///< `text` as a number.
};

/// Every entry, grouped by paper (000 … 004), each group in the paper's table order.
const std::vector<PaperValue>& PaperValues();

/// The entry (paper, table, row, column), nullptr when the paper gives no such value.
const PaperValue* FindPaperValue(std::string_view paper, std::string_view table,
                                 std::string_view row, std::string_view column);
/// Like FindPaperValue, but throws std::logic_error naming the key when there is no entry (for
/// values a section always quotes).
const PaperValue& GetPaperValue(std::string_view paper, std::string_view table,
                                std::string_view row, std::string_view column);
/// The entry's text, `absent` when there is none.
std::string PaperText(std::string_view paper, std::string_view table, std::string_view row,
                      std::string_view column, std::string_view absent = "–");

/// results.json "paper": every entry of `paper` as {table, row, column, value, unit[, source]}
/// with the file name, in the table's order.
Json PaperJson(std::string_view paper);

/// The results.json section (and report section) that quotes `paper`: "hand_array" (000),
/// "tremor_wrist" (001), "elbow_tests" (002), "shoulder" (003), "reaching" (004).
std::string_view PaperSection(std::string_view paper);

/// The entries of PaperValues() that a benchmark run does not quote, one line each
/// ("002 Table 3(a) / TR / FRN 17.76: not in the report's section"): an entry is quoted when its
/// text stands as a number (not part of a longer one) in the report.md section whose heading
/// names "paper NNN", and its (table, row, column, value) in results.json
/// sections.<PaperSection>.paper.values.
std::vector<std::string> UnquotedPaperValues(const std::string& report_md, const Json& results);

}  // namespace fesim::paper_benchmark
