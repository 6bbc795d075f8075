// bus::printable: wire text is escaped once before it reaches a log (issue 13, row 13). No DDS.
#include <ddsnav/bus/printable.hpp>

#include <gtest/gtest.h>

using ddsnav::bus::printable;

TEST(Printable, KeepsPlainTextAndEscapesEverythingElse) {
  EXPECT_EQ(printable("planner: no path"), "planner: no path");
  EXPECT_EQ(printable(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(printable("\x1b[31mred\x1b[0m"), "\\x1b[31mred\\x1b[0m");
  EXPECT_EQ(printable("line\n[12:00:00] [monitor] [info] goal reached"), "line\\n[12:00:00] [monitor] [info] goal reached");
  EXPECT_EQ(printable("tab\there\r\\"), "tab\\there\\r\\\\");
  EXPECT_EQ(printable("\x7f\xff\xc3\xa9"), "\\x7f\\xff\\xc3\\xa9");
}

TEST(Printable, CutsLongTextAndSaysHowLongItWas) {
  const std::string long_text(10000, 'x');
  const auto shown = printable(long_text);
  EXPECT_EQ(shown, std::string(256, 'x') + "...(10000 bytes)");
  EXPECT_EQ(printable("abcdef", 3), "abc...(6 bytes)");
}
