#include "chromo/spectral/table.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

using chromo::spectral::DataError;
using chromo::spectral::parse_table;
using ::testing::HasSubstr;

namespace {

std::string error_of(std::string_view text) {
  try {
    parse_table(text, "t.csv");
  } catch (const DataError& e) {
    return e.what();
  }
  return "no error";
}

TEST(Table, ParsesCommentsHeaderAndRows) {
  const auto t = parse_table("# source line\n# units\nwavelength_nm,a,b\n380,1,2\n385, 3.5 ,4e-1\r\n", "t.csv");
  ASSERT_EQ(t.column_names.size(), 3u);
  EXPECT_EQ(t.rows(), 2u);
  EXPECT_DOUBLE_EQ(t.column("a")[1], 3.5);
  EXPECT_DOUBLE_EQ(t.column("b")[1], 0.4);
}

TEST(Table, RejectsMalformedInputNamingLineAndColumn) {
  EXPECT_THAT(error_of("w,a\n380,1\n385\n"), HasSubstr("t.csv:3: expected 2 fields, found 1"));
  EXPECT_THAT(error_of("w,a\n380,x1\n"), HasSubstr("column 'a': 'x1' is not a finite number"));
  EXPECT_THAT(error_of("w,a\n380,nan\n"), HasSubstr("not a finite number"));
  EXPECT_THAT(error_of("w,a\n380,1,2\n"), HasSubstr("expected 2 fields, found 3"));
  EXPECT_THAT(error_of("# only comments\n"), HasSubstr("no header row"));
  EXPECT_THAT(error_of("w,a\n"), HasSubstr("no data rows"));
  EXPECT_THAT(error_of("w\n1\n"), HasSubstr("at least two columns"));
}

TEST(Table, MissingColumnListsTheAvailableOnes) {
  const auto t = parse_table("wavelength_nm,R,G\n380,1,2\n", "cam.csv");
  try {
    t.column("B");
    FAIL() << "expected DataError";
  } catch (const DataError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no column 'B' (columns: wavelength_nm, R, G)"));
  }
}

TEST(Table, MissingFileIsAnError) {
  EXPECT_THROW(chromo::spectral::read_table("/nonexistent/file.csv"), DataError);
}

}  // namespace
