// The table of the papers' values (paper_benchmark/paper_values.h): lookups return the papers'
// numbers, every entry is a well-formed number copied from its paper, and the check that a
// report quotes every entry finds the one it leaves out.
#include "paper_benchmark/paper_values.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <tuple>

#include "base/trial.h"

namespace fesim::paper_benchmark {
namespace {

TEST(PaperValues, LookupsReturnThePapersNumbers) {
  // Spot checks against the papers' text (papers/…: line numbers in paper_values.cc).
  EXPECT_EQ(GetPaperValue(kPaper000, "Table 1", "Mean", "Time mean").Value(), 1019.0);
  EXPECT_EQ(GetPaperValue(kPaper000, "Table 2", "Mean", "MCP").text, "0.480");
  EXPECT_EQ(GetPaperValue(kPaper001, "Table 5", "l_P=12", "n_P=7 CV").Value(), 63.95);
  EXPECT_EQ(GetPaperValue(kPaper001, "Tables 1-4 (§4.3 text)", "P2", "V sd").Value(), 0.55);
  EXPECT_EQ(GetPaperValue(kPaper002, "Table 1(a)", "Average", "FRN").text, "51.8");
  EXPECT_EQ(GetPaperValue(kPaper002, "Table 2(b)", "Average", "PRMS").Value(), 39.49);
  EXPECT_EQ(GetPaperValue(kPaper002, "Table 3(a)", "TR", "FRN").Value(), 17.76);
  EXPECT_EQ(GetPaperValue(kPaper002, "Table 3(b)", "Staircase", "Staircase").Value(), 84.39);
  EXPECT_EQ(GetPaperValue(kPaper003, "Table II(b)", "model 2", "J_L velocity").Value(), 6.83);
  EXPECT_EQ(GetPaperValue(kPaper004, "Table I", "SCI elbow flexion", "θ0").Value(), 116.0);
  EXPECT_EQ(GetPaperValue(kPaper004, "Table I", "non-SCI shoulder elevation", "k_d").text, "0.003");
  // A value stated in the prose carries where it stands.
  EXPECT_NE(GetPaperValue(kPaper002, "Table 1(a)", "Average", "PRMS").source.find("§7.3"),
            std::string_view::npos);
  // Cells the papers leave blank have no entry.
  EXPECT_EQ(FindPaperValue(kPaper002, "Table 2(a)", "Average", "PRMS"), nullptr);
  EXPECT_EQ(FindPaperValue(kPaper002, "Table 3(a)", "Staircase", "Staircase"), nullptr);
  EXPECT_EQ(PaperText(kPaper002, "Table 3(a)", "Staircase", "Staircase"), "–");
  EXPECT_THROW(GetPaperValue(kPaper001, "Table 5", "l_P=2", "n_P=1 V"), std::logic_error);
}

TEST(PaperValues, EveryEntryIsAUniqueNumberOfAKnownPaper) {
  std::set<std::tuple<std::string_view, std::string_view, std::string_view, std::string_view>> keys;
  for (const PaperValue& v : PaperValues()) {
    const std::string text(v.text);
    char* end = nullptr;
    std::strtod(text.c_str(), &end);
    EXPECT_TRUE(!text.empty() && *end == '\0') << v.table << " " << v.row << " " << text;
    EXPECT_TRUE(keys.insert({v.paper, v.table, v.row, v.column}).second)
        << "duplicate " << v.paper << " " << v.table << " " << v.row << " " << v.column;
    EXPECT_NO_THROW(PaperSection(v.paper)) << v.paper;
  }
}

TEST(PaperValues, EveryTextStandsInItsPaper) {
  // The stored copies sit beside the repository (docs/papers.md); without them, nothing to check.
  const std::string dir = std::string(FESIM_SOURCE_DIR_PATH) + "/../shared/papers/";
  if (!std::filesystem::exists(dir + std::string(kPaper000))) {
    GTEST_SKIP() << "no papers at " << dir;
  }
  for (const PaperValue& v : PaperValues()) {
    const std::string paper = ReadFile(dir + std::string(v.paper));
    EXPECT_NE(paper.find(std::string(v.text)), std::string::npos)
        << v.paper << " " << v.table << " " << v.row << " " << v.column << " " << v.text;
  }
}

/// A report and results.json that quote every entry except `skip` (nullptr: none).
std::pair<std::string, Json> QuotingReport(const PaperValue* skip_md, const PaperValue* skip_json) {
  std::string md = "# fesim benchmark\n\n";
  Json sections = Json::Object();
  for (std::string_view paper : {kPaper000, kPaper001, kPaper002, kPaper003, kPaper004}) {
    md += "## Section (paper " + std::string(paper.substr(0, 3)) + ")\n\n| fesim 12.345 |";
    Json values = Json::Array();
    for (const PaperValue& v : PaperValues()) {
      if (v.paper != paper) continue;
      if (&v != skip_md) md += " [" + std::string(v.text) + "] |";
      if (&v == skip_json) continue;
      Json e = Json::Object();
      e.Set("table", std::string(v.table)).Set("row", std::string(v.row));
      e.Set("column", std::string(v.column)).Set("value", v.Value());
      values.Push(e);
    }
    md += "\n\n";
    Json block = Json::Object();
    block.Set("values", values);
    Json section = Json::Object();
    section.Set("paper", block);
    sections.Set(std::string(PaperSection(paper)), section);
  }
  Json results = Json::Object();
  results.Set("sections", sections);
  return {md, results};
}

TEST(PaperValues, UnquotedValuesAreNamed) {
  const auto [md, results] = QuotingReport(nullptr, nullptr);
  EXPECT_TRUE(UnquotedPaperValues(md, results).empty());

  const PaperValue& elbow = GetPaperValue(kPaper002, "Table 3(a)", "TR", "FRN");
  const auto [md2, results2] = QuotingReport(&elbow, nullptr);
  const auto missing = UnquotedPaperValues(md2, results2);
  ASSERT_EQ(missing.size(), 1u);
  EXPECT_EQ(missing[0], "002 Table 3(a) / TR / FRN 17.76: not in the report's section");

  const PaperValue& reach = GetPaperValue(kPaper004, "Table I", "SCI elbow flexion", "k_s");
  const auto [md3, results3] = QuotingReport(nullptr, &reach);
  const auto missing3 = UnquotedPaperValues(md3, results3);
  ASSERT_EQ(missing3.size(), 1u);
  EXPECT_NE(missing3[0].find("results.json"), std::string::npos) << missing3[0];

  // In another paper's section, or only inside a longer number, a value is not quoted.
  const std::string cell = " [17.76] |";
  std::string moved = md;
  moved.erase(moved.find(cell), cell.size());
  EXPECT_EQ(UnquotedPaperValues(moved + "## Shoulder (paper 003)\n| 17.76 |\n", results).size(),
            1u);
  std::string longer = md;
  longer.replace(longer.find(cell), cell.size(), " 117.76 | 17.761 | 17.76.5 |");
  EXPECT_EQ(UnquotedPaperValues(longer, results).size(), 1u);
}

}  // namespace
}  // namespace fesim::paper_benchmark
