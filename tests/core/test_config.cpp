#include <gtest/gtest.h>

#include "obm/config/config_node.hpp"

using namespace obm;

TEST(Config, OptionalRequiredAndUnknownKeys) {
  const auto c = ConfigNode::fromString("a: 2\nsub:\n  b: 0.5\n  angle_deg: 90\n", "test.yaml");
  int a = 1;
  double missing = 7.0;
  c.get("a", a);
  c.get("nope", missing);
  EXPECT_EQ(a, 2);
  EXPECT_EQ(missing, 7.0);
  double rad = 0;
  c.child("sub").getDegAsRad("angle_deg", rad);
  EXPECT_NEAR(rad, M_PI / 2, 1e-12);
  try {
    c.required<int>("zzz");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("test.yaml: zzz"), std::string::npos) << e.what();
  }
  try {
    c.child("sub").checkKeys({"b"});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("sub.angle_deg"), std::string::npos) << e.what();
  }
  EXPECT_THROW(c.child("sub").required<int>("b"), ConfigError);  // 0.5 is not an int
  EXPECT_THROW(ConfigNode::loadFile("/nonexistent.yaml"), IoError);
  EXPECT_THROW(ConfigNode::fromString("a: [1, 2\n", "bad.yaml"), ConfigError);
}
