// Issue 41, problem 9: a mistyped command or option gets the nearest known
// word ("did you mean"), on the real chromo binary; a word nothing is near
// gets no guess. Every one still exits 2 and does nothing.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "run_chromo.hpp"

namespace {
using ::testing::HasSubstr;
using ::testing::Not;

TEST(TypoSuggestion, AMistypedCommandNamesTheNearestOne) {
  Result top = run_chromo("sesion list");
  EXPECT_EQ(top.exit_status, 2);
  EXPECT_THAT(top.output, HasSubstr("did you mean `chromo session`?"));
  Result sub = run_chromo("session lst");
  EXPECT_EQ(sub.exit_status, 2);
  EXPECT_THAT(sub.output, HasSubstr("did you mean `chromo session list`?"));
}

TEST(TypoSuggestion, AMistypedOptionNamesTheNearestOneOfItsCommand) {
  Result run = run_chromo("session run --subjet forearm --daemon unix:/nonexistent/chromod.sock");
  EXPECT_EQ(run.exit_status, 2);
  EXPECT_THAT(run.output, HasSubstr("did you mean `--subject`?"));
}

TEST(TypoSuggestion, NothingCloseGetsNoGuess) {
  Result far = run_chromo("photosynthesis");
  EXPECT_EQ(far.exit_status, 2);
  EXPECT_THAT(far.output, Not(HasSubstr("did you mean")));
}

}  // namespace
