// The Server-Sent Events framing of web/sse.h: what a browser's EventSource
// parses back into the event's id, type and data.
#include "web/sse.h"

#include <string>

#include "gtest/gtest.h"

namespace riskplan::web {
namespace {

TEST(SseFramingTest, OneLineOfData) {
  EXPECT_EQ(FormatSseEvent(7, "update", R"({"risk":1e-7})"),
            "id: 7\nevent: update\ndata: {\"risk\":1e-7}\n\n");
}

TEST(SseFramingTest, EveryKindOfLineBreakStartsADataLine) {
  // The browser joins data lines with "\n": a "\r" or "\r\n" in the data
  // must not end the event or leak into a field name.
  EXPECT_EQ(FormatSseEvent(1, "failed", "a\nb"), "id: 1\nevent: failed\ndata: a\ndata: b\n\n");
  EXPECT_EQ(FormatSseEvent(1, "failed", "a\r\nb"), "id: 1\nevent: failed\ndata: a\ndata: b\n\n");
  EXPECT_EQ(FormatSseEvent(1, "failed", "a\rb"), "id: 1\nevent: failed\ndata: a\ndata: b\n\n");
  EXPECT_EQ(FormatSseEvent(1, "failed", "a\n\nb"),
            "id: 1\nevent: failed\ndata: a\ndata: \ndata: b\n\n");
  EXPECT_EQ(FormatSseEvent(1, "failed", "a\n"), "id: 1\nevent: failed\ndata: a\ndata: \n\n");
}

TEST(SseFramingTest, EmptyDataIsOneEmptyLine) {
  EXPECT_EQ(FormatSseEvent(18446744073709551615ull, "cancelled", ""),
            "id: 18446744073709551615\nevent: cancelled\ndata: \n\n");
}

TEST(SseFramingTest, CommentAndRetry) {
  EXPECT_EQ(FormatSseComment("waiting"), ": waiting\n\n");
  EXPECT_EQ(FormatSseRetry(1000), "retry: 1000\n\n");
}

TEST(SseLastEventIdTest, Parses) {
  EXPECT_EQ(ParseLastEventId(""), 0u);
  EXPECT_EQ(ParseLastEventId("0"), 0u);
  EXPECT_EQ(ParseLastEventId("42"), 42u);
  EXPECT_EQ(ParseLastEventId(" 42 "), 42u);
  EXPECT_EQ(ParseLastEventId("9999999999999999999"), 9999999999999999999ull);
}

TEST(SseLastEventIdTest, RefusesWhatIsNotAnId) {
  EXPECT_FALSE(ParseLastEventId("-1").has_value());
  EXPECT_FALSE(ParseLastEventId("+1").has_value());
  EXPECT_FALSE(ParseLastEventId("1.5").has_value());
  EXPECT_FALSE(ParseLastEventId("abc").has_value());
  EXPECT_FALSE(ParseLastEventId("0x10").has_value());
  EXPECT_FALSE(ParseLastEventId("12345678901234567890").has_value());  // 20 digits
  EXPECT_FALSE(ParseLastEventId("4 2").has_value());
}

}  // namespace
}  // namespace riskplan::web
