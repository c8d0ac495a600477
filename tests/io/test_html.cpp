#include <gtest/gtest.h>

#include "io/html.h"

namespace mosyn::io {
namespace {

TEST(HtmlTest, EscapesMarkupAndQuotes) {
  EXPECT_EQ(escape_html("a<b & \"c\" 'd'>"), "a&lt;b &amp; &quot;c&quot; &#39;d&#39;&gt;");
  EXPECT_EQ(escape_html("plain"), "plain");
}

}  // namespace
}  // namespace mosyn::io
