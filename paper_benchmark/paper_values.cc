// The papers' values that the benchmark report quotes (paper_values.h). Each group's comment
// says where the values stand in the stored copy in papers/ (line numbers of that file); the
// texts are copied digit for digit. Values the copies hold only in figures are not here.
#include "paper_benchmark/paper_values.h"

#include <cstdlib>
#include <iterator>
#include <stdexcept>

namespace fesim::paper_benchmark {

namespace {

constexpr std::string_view kT1 = "Table 1", kT2 = "Table 2";

/// The table, in the order of paper_values.h.
constexpr PaperValue kValues[] = {
    // ---- 000 [Hand Hammerstein] §5.2, Tables 1 (model (12)) and 2 (Hammerstein model (16)):
    // the "Mean" rows (lines 337 and 351): normalised error per joint, time per local
    // optimisation step (s). The participants' rows are not quoted: fesim's virtual
    // participants are not the paper's.
    {kPaper000, kT1, "Mean", "Wrist", "0.617", "", ""},
    {kPaper000, kT1, "Mean", "MCP", "0.500", "", ""},
    {kPaper000, kT1, "Mean", "PIP", "0.744", "", ""},
    {kPaper000, kT1, "Mean", "Time mean", "1019", "s", ""},
    {kPaper000, kT2, "Mean", "Wrist", "0.499", "", ""},
    {kPaper000, kT2, "Mean", "MCP", "0.480", "", ""},
    {kPaper000, kT2, "Mean", "PIP", "0.636", "", ""},
    {kPaper000, kT2, "Mean", "Time mean", "0.178", "s", ""},
    // §5.1, line 313: "... and two parameters of matrix R(y), giving a total of 29 parameters".
    {kPaper000, "§5.1 text", "model (12)", "parameters fitted", "29", "", ""},
    // §5.2, line 323: "On average the error obtained using the Hammerstein model (16) is 13.2%
    // lower".
    {kPaper000, "§5.2 text", "model (16) vs (12)", "mean error reduction", "13.2", "%", ""},

    // ---- 001 [Copur 2016] §4.3, Table 5 (lines 418-440): mean V / CV Best Fit over the four
    // participants, rows l_P, columns n_P, m_P = 1 (rows are l_P: the best CV cell, 63.95, is
    // at row 12, column 7, and the text names n_P = 7, l_P = 12 the best). Only the cells of
    // fesim's sweep grid (l_P ∈ {2, 4, 8, 12}, n_P ∈ {1, 3, 7, 12}) that the paper's 4-12 grid
    // holds. The copy garbles the row labels of the V rows; each V row follows its l_P's CV row.
    {kPaper001, "Table 5", "l_P=4", "n_P=7 CV", "59.87", "%", ""},    // line 421
    {kPaper001, "Table 5", "l_P=4", "n_P=7 V", "61.63", "%", ""},     // line 422
    {kPaper001, "Table 5", "l_P=8", "n_P=7 CV", "63.39", "%", ""},    // line 429
    {kPaper001, "Table 5", "l_P=8", "n_P=7 V", "66.30", "%", ""},     // line 430
    {kPaper001, "Table 5", "l_P=12", "n_P=7 CV", "63.95", "%", ""},   // line 437
    {kPaper001, "Table 5", "l_P=12", "n_P=7 V", "68.52", "%", ""},    // line 438
    {kPaper001, "Table 5", "l_P=4", "n_P=12 CV", "60.62", "%", ""},   // line 421
    {kPaper001, "Table 5", "l_P=4", "n_P=12 V", "63.03", "%", ""},    // line 422
    {kPaper001, "Table 5", "l_P=8", "n_P=12 CV", "63.23", "%", ""},   // line 429
    {kPaper001, "Table 5", "l_P=8", "n_P=12 V", "66.66", "%", ""},    // line 430
    {kPaper001, "Table 5", "l_P=12", "n_P=12 CV", "63.46", "%", ""},  // line 437
    {kPaper001, "Table 5", "l_P=12", "n_P=12 V", "68.48", "%", ""},   // line 438
    // §4.3, line 447: "the mean and standard deviation of the Best Fit values in Table 1 to
    // Table 4 which are 66.61 (4.12), 57.95 (0.73), 59.51 (1.26) and 65.57 (1.39) for
    // cross-validation tests and 70.79 (4.12), 62.29 (0.55), 63.14 (3.23) and 66.76 (2.26) for
    // validation tests" (one per participant P1-P4, over l_P, n_P ∈ 4-12).
    {kPaper001, "Tables 1-4 (§4.3 text)", "P1", "CV mean", "66.61", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P1", "CV sd", "4.12", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P1", "V mean", "70.79", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P1", "V sd", "4.12", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P2", "CV mean", "57.95", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P2", "CV sd", "0.73", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P2", "V mean", "62.29", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P2", "V sd", "0.55", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P3", "CV mean", "59.51", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P3", "CV sd", "1.26", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P3", "V mean", "63.14", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P3", "V sd", "3.23", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P4", "CV mean", "65.57", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P4", "CV sd", "1.39", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P4", "V mean", "66.76", "%", ""},
    {kPaper001, "Tables 1-4 (§4.3 text)", "P4", "V sd", "2.26", "%", ""},
    // §4.3, line 447: "Validation and cross-validation Best Fit values in all tables are higher
    // than 50%".
    {kPaper001, "§4.3 text", "Tables 1-5", "lower bound of V and CV", "50", "%", ""},

    // ---- 002 [Le 2010] §6.2, Table 1 (identification), "Average" rows: (a) Algorithm 1 line
    // 384, (b) Algorithm 2 line 396.
    {kPaper002, "Table 1(a)", "Average", "TR", "90.15", "%", ""},
    {kPaper002, "Table 1(a)", "Average", "FRN", "51.8", "%", ""},
    {kPaper002, "Table 1(a)", "Average", "Staircase", "88.46", "%", ""},
    {kPaper002, "Table 1(a)", "Average", "PRMS", "48", "%",
     "§7.3 text, line 498 (\"the average identification results for Algorithm 1 are 51.8% and "
     "48%\"); the table's cell is blank"},
    {kPaper002, "Table 1(b)", "Average", "TR", "93.33", "%", ""},
    {kPaper002, "Table 1(b)", "Average", "FRN", "68.03", "%", ""},
    {kPaper002, "Table 1(b)", "Average", "Staircase", "93.04", "%", ""},
    {kPaper002, "Table 1(b)", "Average", "PRMS", "68.88", "%", ""},
    // Table 2 (validation), "Average" rows: (a) line 415 (its PRMS cell is blank), (b) line 427.
    {kPaper002, "Table 2(a)", "Average", "TR", "81.60", "%", ""},
    {kPaper002, "Table 2(a)", "Average", "FRN", "25.91", "%", ""},
    {kPaper002, "Table 2(a)", "Average", "Staircase", "79.87", "%", ""},
    {kPaper002, "Table 2(b)", "Average", "TR", "78.00", "%", ""},
    {kPaper002, "Table 2(b)", "Average", "FRN", "22.78", "%", ""},
    {kPaper002, "Table 2(b)", "Average", "Staircase", "81.58", "%", ""},
    {kPaper002, "Table 2(b)", "Average", "PRMS", "39.49", "%", ""},
    // Table 3 (cross-validation; rows: identified on, columns: validated on; TR, FRN and
    // staircase only), (a) Algorithm 1 lines 444-446, (b) Algorithm 2 lines 448-450. Row
    // "Staircase" of (a) holds two values in the copy; they are taken as its first two
    // columns (TR, FRN), the staircase cell as blank.
    {kPaper002, "Table 3(a)", "TR", "TR", "84.83", "%", ""},
    {kPaper002, "Table 3(a)", "TR", "FRN", "17.76", "%", ""},
    {kPaper002, "Table 3(a)", "TR", "Staircase", "47.94", "%", ""},
    {kPaper002, "Table 3(a)", "FRN", "TR", "83.96", "%", ""},
    {kPaper002, "Table 3(a)", "FRN", "FRN", "40.23", "%", ""},
    {kPaper002, "Table 3(a)", "FRN", "Staircase", "71.40", "%", ""},
    {kPaper002, "Table 3(a)", "Staircase", "TR", "79.53", "%", ""},
    {kPaper002, "Table 3(a)", "Staircase", "FRN", "42.67", "%", ""},
    {kPaper002, "Table 3(b)", "TR", "TR", "81.80", "%", ""},
    {kPaper002, "Table 3(b)", "TR", "FRN", "41.08", "%", ""},
    {kPaper002, "Table 3(b)", "TR", "Staircase", "64.11", "%", ""},
    {kPaper002, "Table 3(b)", "FRN", "TR", "68.75", "%", ""},
    {kPaper002, "Table 3(b)", "FRN", "FRN", "46.80", "%", ""},
    {kPaper002, "Table 3(b)", "FRN", "Staircase", "67.86", "%", ""},
    {kPaper002, "Table 3(b)", "Staircase", "TR", "80.72", "%", ""},
    {kPaper002, "Table 3(b)", "Staircase", "FRN", "45.00", "%", ""},
    {kPaper002, "Table 3(b)", "Staircase", "Staircase", "84.39", "%", ""},
    // §7.2, line 486: "Algorithm 2 improves the average results by up to 20% compared with
    // Algorithm 1, as shown in Table 1".
    {kPaper002, "§7.2 text", "Algorithm 2 vs 1", "identification gain, up to", "20", "%", ""},

    // ---- 003 [Spagnol 2013] §III, performance indices on the identification data: Table I(b)
    // (model 1, line 4: "J L ( ˆ 7.39%") and Table II(b) (model 2, line 5: "J L ( ˆ 6.83%"),
    // J_L of the angular velocity (the first of each table's two indices, the order in which
    // §III-A defines them: velocity, then position; the copy lost the symbols). The copy loses
    // the digits 0, 1, 2 and 4 (its header reads
    // "ECC July 7-9, 3" for 17-19 July 2013): these two keep two decimals like the paper's
    // other indices and are quoted as printed; the position indices ("5.7%", "7.5%"), the
    // parameters of Tables I(a), II(a) and the errors of Tables III-IV ("-.", ".6") have lost
    // digits and are left out.
    {kPaper003, "Table I(b)", "model 1", "J_L velocity", "7.39", "%",
     "as printed in the stored copy, which drops the digits 0, 1, 2 and 4"},
    {kPaper003, "Table II(b)", "model 2", "J_L velocity", "6.83", "%",
     "as printed in the stored copy, which drops the digits 0, 1, 2 and 4"},

    // ---- 004 [Schearer 2014] §III, Table I (lines 179-188): parametric model coefficients
    // θ0 (deg), k_s (N-m/deg), k_d (N-m/deg/s); shoulder rotation not reported (line 173: not
    // significantly greater than zero).
    {kPaper004, "Table I", "SCI elevation plane", "θ0", "82", "deg", ""},
    {kPaper004, "Table I", "SCI elevation plane", "k_s", "0.13", "N·m/deg", ""},
    {kPaper004, "Table I", "SCI elevation plane", "k_d", "0.070", "N·m·s/deg", ""},
    {kPaper004, "Table I", "non-SCI elevation plane", "θ0", "14", "deg", ""},
    {kPaper004, "Table I", "non-SCI elevation plane", "k_s", "0.01", "N·m/deg", ""},
    {kPaper004, "Table I", "non-SCI elevation plane", "k_d", "0.007", "N·m·s/deg", ""},
    {kPaper004, "Table I", "SCI shoulder elevation", "θ0", "49", "deg", ""},
    {kPaper004, "Table I", "SCI shoulder elevation", "k_s", "0.12", "N·m/deg", ""},
    {kPaper004, "Table I", "SCI shoulder elevation", "k_d", "0.064", "N·m·s/deg", ""},
    {kPaper004, "Table I", "non-SCI shoulder elevation", "θ0", "17", "deg", ""},
    {kPaper004, "Table I", "non-SCI shoulder elevation", "k_s", "0.10", "N·m/deg", ""},
    {kPaper004, "Table I", "non-SCI shoulder elevation", "k_d", "0.003", "N·m·s/deg", ""},
    {kPaper004, "Table I", "SCI elbow flexion", "θ0", "116", "deg", ""},
    {kPaper004, "Table I", "SCI elbow flexion", "k_s", "0.08", "N·m/deg", ""},
    {kPaper004, "Table I", "SCI elbow flexion", "k_d", "0.051", "N·m·s/deg", ""},
    {kPaper004, "Table I", "non-SCI elbow flexion", "θ0", "81", "deg", ""},
    {kPaper004, "Table I", "non-SCI elbow flexion", "k_s", "0.04", "N·m/deg", ""},
    {kPaper004, "Table I", "non-SCI elbow flexion", "k_d", "0.009", "N·m·s/deg", ""},
    // §III text on Fig. 5 (the box plots themselves are only in the figure): line 175, "The
    // semiparametric model predicted joint torques for a subject without spinal cord injury
    // generally within 20% of the maximum torque"; line 190, "Errors were between 10% and 40%
    // for the semiparametric model" (subject with SCI).
    {kPaper004, "§III text (Fig. 5(a))", "non-SCI semiparametric", "LOOCV error, generally within",
     "20", "% of max |torque|", ""},
    {kPaper004, "§III text (Fig. 5(b))", "SCI semiparametric", "LOOCV error, from", "10",
     "% of max |torque|", ""},
    {kPaper004, "§III text (Fig. 5(b))", "SCI semiparametric", "LOOCV error, to", "40",
     "% of max |torque|", ""},
    // §II.A protocols (line 74, subject without SCI: "The distance from each home position to
    // each target position varied from 12 cm to 45 cm, and the time to reach from home to target
    // was a constant two seconds, so the maximum speed of the hand ... varied from 11 cm/s to
    // 42 cm/s"; line 76, subject with SCI: "16 cm to 36 cm ... a constant three seconds ...
    // from 10 cm/s to 23 cm/s", "Four randomly selected trajectories ... repeated three times
    // for a total of 12 trajectories"), and §II.C (line 158): 18 and four training sets.
    {kPaper004, "§II.A text", "non-SCI", "unique trajectories", "18", "", ""},
    {kPaper004, "§II.A text", "non-SCI", "reaches", "54", "", ""},
    {kPaper004, "§II.A text", "non-SCI", "reach duration", "2", "s", ""},
    {kPaper004, "§II.A text", "non-SCI", "distance from", "12", "cm", ""},
    {kPaper004, "§II.A text", "non-SCI", "distance to", "45", "cm", ""},
    {kPaper004, "§II.A text", "non-SCI", "peak hand speed from", "11", "cm/s", ""},
    {kPaper004, "§II.A text", "non-SCI", "peak hand speed to", "42", "cm/s", ""},
    {kPaper004, "§II.A text", "SCI", "unique trajectories", "4", "", ""},
    {kPaper004, "§II.A text", "SCI", "reaches", "12", "", ""},
    {kPaper004, "§II.A text", "SCI", "reach duration", "3", "s", ""},
    {kPaper004, "§II.A text", "SCI", "distance from", "16", "cm", ""},
    {kPaper004, "§II.A text", "SCI", "distance to", "36", "cm", ""},
    {kPaper004, "§II.A text", "SCI", "peak hand speed from", "10", "cm/s", ""},
    {kPaper004, "§II.A text", "SCI", "peak hand speed to", "23", "cm/s", ""},
};

const std::vector<PaperValue>& Values() {
  static const std::vector<PaperValue> k(std::begin(kValues), std::end(kValues));
  return k;
}

}  // namespace

double PaperValue::Value() const { return std::strtod(std::string(text).c_str(), nullptr); }

const std::vector<PaperValue>& PaperValues() { return Values(); }

const PaperValue* FindPaperValue(std::string_view paper, std::string_view table,
                                 std::string_view row, std::string_view column) {
  for (const PaperValue& v : Values()) {
    if (v.paper == paper && v.table == table && v.row == row && v.column == column) return &v;
  }
  return nullptr;
}

const PaperValue& GetPaperValue(std::string_view paper, std::string_view table,
                                std::string_view row, std::string_view column) {
  const PaperValue* v = FindPaperValue(paper, table, row, column);
  if (v == nullptr) {
    throw std::logic_error("paper values: no entry " + std::string(paper) + " " +
                           std::string(table) + " / " + std::string(row) + " / " +
                           std::string(column));
  }
  return *v;
}

std::string PaperText(std::string_view paper, std::string_view table, std::string_view row,
                      std::string_view column, std::string_view absent) {
  const PaperValue* v = FindPaperValue(paper, table, row, column);
  return std::string(v != nullptr ? v->text : absent);
}

Json PaperJson(std::string_view paper) {
  Json values = Json::Array();
  for (const PaperValue& v : Values()) {
    if (v.paper != paper) continue;
    Json e = Json::Object();
    e.Set("table", std::string(v.table)).Set("row", std::string(v.row));
    e.Set("column", std::string(v.column)).Set("value", v.Value());
    e.Set("unit", std::string(v.unit));
    if (!v.source.empty()) e.Set("source", std::string(v.source));
    values.Push(e);
  }
  Json block = Json::Object();
  block.Set("file", std::string(paper));
  block.Set("values", values);
  return block;
}

std::string_view PaperSection(std::string_view paper) {
  if (paper == kPaper000) return "hand_array";
  if (paper == kPaper001) return "tremor_wrist";
  if (paper == kPaper002) return "elbow_tests";
  if (paper == kPaper003) return "shoulder";
  if (paper == kPaper004) return "reaching";
  throw std::logic_error("paper values: no section for " + std::string(paper));
}

namespace {

/// The "## " section of `md` whose heading names "paper NNN" (NNN: the file's number), "" when
/// there is none.
std::string ReportSection(const std::string& md, std::string_view paper) {
  const std::string name = "paper " + std::string(paper.substr(0, 3));
  std::size_t at = 0;
  while ((at = md.find("## ", at)) != std::string::npos) {
    const std::size_t eol = md.find('\n', at);
    const bool heading = at == 0 || md[at - 1] == '\n';
    if (heading && md.substr(at, eol - at).find(name) != std::string::npos) {
      const std::size_t end = md.find("\n## ", at);
      return md.substr(at, end == std::string::npos ? std::string::npos : end - at);
    }
    at = eol;
  }
  return std::string();
}

bool IsDigit(char c) { return c >= '0' && c <= '9'; }

/// Whether `number` stands in `text` as a whole number: no digit or decimal point before it, no
/// digit and no decimal point followed by a digit after it.
bool ContainsNumber(const std::string& text, std::string_view number) {
  for (std::size_t at = text.find(number); at != std::string::npos;
       at = text.find(number, at + 1)) {
    const std::size_t end = at + number.size();
    const bool before = at > 0 && (IsDigit(text[at - 1]) || text[at - 1] == '.');
    const bool after = end < text.size() &&
                       (IsDigit(text[end]) ||
                        (text[end] == '.' && end + 1 < text.size() && IsDigit(text[end + 1])));
    if (!before && !after) return true;
  }
  return false;
}

/// Whether results.json's `paper` block holds the entry.
bool InJson(const Json& results, const PaperValue& v) {
  const Json* sections = results.Find("sections");
  const Json* section = sections ? sections->Find(std::string(PaperSection(v.paper))) : nullptr;
  const Json* block = section ? section->Find("paper") : nullptr;
  const Json* values = block ? block->Find("values") : nullptr;
  if (values == nullptr || !values->IsArray()) return false;
  for (const Json& e : values->Items()) {
    const auto is = [&](const char* key, std::string_view want) {
      const Json* j = e.Find(key);
      return j != nullptr && j->IsString() && j->AsString() == want;
    };
    const Json* value = e.Find("value");
    if (is("table", v.table) && is("row", v.row) && is("column", v.column) && value != nullptr &&
        value->IsNumber() && value->AsNumber() == v.Value())
      return true;
  }
  return false;
}

}  // namespace

std::vector<std::string> UnquotedPaperValues(const std::string& report_md, const Json& results) {
  std::vector<std::string> missing;
  for (const PaperValue& v : Values()) {
    const std::string id = std::string(v.paper.substr(0, 3)) + " " + std::string(v.table) + " / " +
                           std::string(v.row) + " / " + std::string(v.column) + " " +
                           std::string(v.text);
    if (!ContainsNumber(ReportSection(report_md, v.paper), v.text))
      missing.push_back(id + ": not in the report's section");
    if (!InJson(results, v)) missing.push_back(id + ": not in results.json's paper block");
  }
  return missing;
}

}  // namespace fesim::paper_benchmark
