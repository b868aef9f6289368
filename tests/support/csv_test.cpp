// SPDX-License-Identifier: Apache-2.0
// The one strict CSV reader (imm/support/csv.hpp): what a number is, and that each of its three
// uses — measurement CSVs, published rule tables, sensor samples — refuses trailing garbage
// ("1.0oops") naming the file, the line and the column.

#include "imm/support/csv.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "imm/datasets/range_sensor_file.hpp"
#include "imm/io/file_error.hpp"
#include "imm/support/measurement_csv.hpp"
#include "imm/trainer/model_files/import_rules.hpp"
#include "testing/temp_dir.hpp"

namespace imm::support {
namespace {

TEST(Csv, ANumberIsTheWholeField) {
  for (const char* bad : {"1.0oops", "1 2", "", " ", "0x10", "1e", "1,0", "--1", "+-1", "+", "."}) {
    EXPECT_FALSE(parse_real(bad)) << "'" << bad << "'";
  }
  EXPECT_EQ(parse_real("+2"), 2.0);
  EXPECT_EQ(parse_real(" -3.5e-2 "), -3.5e-2);
  EXPECT_EQ(parse_real("0.1"), 0.1);  // the correctly rounded double
  EXPECT_FALSE(parse_real("nan"));
  EXPECT_FALSE(parse_real("inf"));
  EXPECT_FALSE(parse_real("1e999"));  // out of range
  EXPECT_TRUE(std::isnan(*parse_real("nan", /*finite_only=*/false)));
  EXPECT_EQ(parse_integer("+7"), 7);
  EXPECT_EQ(parse_integer("-12"), -12);
  EXPECT_FALSE(parse_integer("12.0"));
  EXPECT_FALSE(parse_integer("12k"));
}

TEST(Csv, ReaderSkipsBlanksAndCommentsAndReturnsDirectivesWhenAsked) {
  std::istringstream text("# note\n\n#@ units = km \n a , b \r\n1,2\n");
  CsvReader reader(text, "t.csv", /*directives=*/true);
  CsvLine line;
  ASSERT_TRUE(reader.next(line));
  EXPECT_TRUE(line.directive);
  EXPECT_EQ(line.key, "units");
  EXPECT_EQ(line.value, "km");
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(line.number, 4u);
  EXPECT_EQ(line.fields, (std::vector<std::string_view>{"a", "b"}));
  ASSERT_TRUE(reader.next(line));
  EXPECT_EQ(reader.real(line, 1, "b"), 2.0);
  EXPECT_EQ(reader.where(), "t.csv:5");
  EXPECT_FALSE(reader.next(line));
}

// A spreadsheet's "CSV UTF-8" export: a byte order mark before the header and CRLF line ends.
// The mark is dropped from the first line only (elsewhere it is text, refused as a field's).
TEST(Csv, AByteOrderMarkBeforeTheFirstLineIsNotPartOfIt) {
  const std::string mark = "\xEF\xBB\xBF";
  std::istringstream text(mark + "k,zx,zy\r\n0,1.0,2.0\r\n1,3.0,4.0\r\n");
  const MeasurementCsv csv = read_measurement_csv(text, "excel.csv");
  ASSERT_EQ(csv.rows.size(), 2u);
  for (const MeasurementRow& row : csv.rows) EXPECT_EQ(row.problem, "") << row.line;
  EXPECT_EQ(csv.rows[1].z, Eigen::Vector2d(3.0, 4.0));
  std::istringstream inner("a,b\n" + mark + "1,2\n");
  CsvReader reader(inner, "t.csv");
  CsvLine line;
  ASSERT_TRUE(reader.next(line) && reader.next(line));
  EXPECT_EQ(line.fields[0], mark + "1");
  EXPECT_FALSE(parse_real(line.fields[0]));
}

// Named columns after the plot's are carried along unread (imm-data export's truth); each row then
// holds as many fields as the header, and an unnamed column is refused.
TEST(Csv, MeasurementsCarryNamedColumnsAfterThePlotsUnread) {
  std::istringstream text(
      "t,zx,zy,x,vx,y,vy\n0,1.0,2.0,1.1,5,2.1,6\n1,3.0,4.0\n2,5.0,6.0,a,b,c,d\n");
  const MeasurementCsv csv = read_measurement_csv(text, "export.csv");
  ASSERT_EQ(csv.rows.size(), 3u);
  EXPECT_TRUE(csv.timed);
  EXPECT_EQ(csv.rows[0].z, Eigen::Vector2d(1.0, 2.0));
  EXPECT_EQ(csv.rows[1].problem, "expected 7 fields, found 3");
  EXPECT_EQ(csv.rows[2].problem, "");  // unread, whatever they hold
  std::istringstream unnamed("k,zx,zy,\n0,1.0,2.0,\n");
  try {
    (void)read_measurement_csv(unnamed, "unnamed.csv");
    ADD_FAILURE() << "an unnamed column was taken";
  } catch (const std::runtime_error& error) {
    EXPECT_STREQ(error.what(), "unnamed.csv:1: column 4 has no name");
  }
}

TEST(Csv, MeasurementsRefuseTrailingGarbage) {
  std::istringstream text("k,zx,zy\n0,1.0,2.0\n1,1.0oops,2.0\n2,3.0,4.0x\n");
  const MeasurementCsv csv = read_measurement_csv(text, "plots.csv");
  ASSERT_EQ(csv.rows.size(), 3u);
  EXPECT_EQ(csv.rows[0].problem, "");
  EXPECT_EQ(csv.rows[1].problem, "zx '1.0oops' is not a number");
  EXPECT_EQ(csv.rows[1].line, 3u);
  EXPECT_EQ(csv.rows[2].problem, "zy '4.0x' is not a number");
}

TEST(Csv, RuleTablesRefuseTrailingGarbage) {
  testing::TempDir dir;
  const auto path = dir.path() / "rules.csv";
  const std::string head =
      "#@ units = km\n#@ sample_period = 1.0\n#@ measurement_sigma = 0.5\n"
      "level,c1,sigma1,c2,sigma2,w\n";
  AxisImmSettings settings;
  settings.sample_period = 1.0;
  settings.sample_period = 1.0;
  settings.measurement_sigma = 0.5;
  { std::ofstream(path) << head << "0.001,1.0oops,0.4,0.2,2.5,0.2e-5\n"; }
  try {
    (void)trainer::read_rules_csv(path, settings, "km");
    ADD_FAILURE() << "1.0oops accepted";
  } catch (const std::runtime_error& error) {
    EXPECT_NE(std::string(error.what()).find("rules.csv:5: c1 ('1.0oops') is not a finite number"),
              std::string::npos)
        << error.what();
  }
  {
    std::ofstream(path) << "#@ units = km\n#@ sample_period = 1.0s\n#@ measurement_sigma = 0.5\n"
                        << "level,c1,sigma1,c2,sigma2,w\n0.001,1.0,0.4,0.2,2.5,0.2e-5\n";
  }
  EXPECT_THROW((void)trainer::read_rules_csv(path, settings, "km"), std::runtime_error);
}

TEST(Csv, SensorSamplesRefuseTrailingGarbage) {
  testing::TempDir dir;
  const auto path = dir.path() / "samples.csv";
  {
    std::ofstream out(path);
    out << "xi,eta,z1,z2\n";
    for (int i = 0; i < 12; ++i) out << i << ",2,3,4\n";
    out << "1,2,3.0oops,4\n";
  }
  try {
    (void)datasets::read_sensor_samples(path);
    ADD_FAILURE() << "3.0oops accepted";
  } catch (const io::FileError& error) {
    EXPECT_NE(std::string(error.what()).find("samples.csv:14"), std::string::npos) << error.what();
    EXPECT_NE(std::string(error.what()).find("z1 ('3.0oops') is not a finite number"),
              std::string::npos)
        << error.what();
  }
}

}  // namespace
}  // namespace imm::support
