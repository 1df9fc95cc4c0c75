#include <gtest/gtest.h>

#include "obm/config/config_node.hpp"
#include "obm/config/overrides.hpp"

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

TEST(ConfigOverrides, SetsNestedValuesAndCreatesMaps) {
  auto c = ConfigNode::fromString("model:\n  use_nmm: true\n  k1: 5\ntrain:\n  lr: 0.001\n",
                                  "o.yaml");
  applyOverrides(c, {"model.use_nmm=false", "model.k1=16", "train.lr_steps=[12, 20]",
                     "data.objects.seed=3"});
  bool nmm = true;
  int k1 = 0, seed = 0;
  std::vector<int> steps;
  c.child("model").get("use_nmm", nmm);
  c.child("model").get("k1", k1);
  c.child("train").get("lr_steps", steps);
  c.child("data").child("objects").get("seed", seed);
  EXPECT_FALSE(nmm);
  EXPECT_EQ(k1, 16);
  EXPECT_EQ(steps, (std::vector<int>{12, 20}));
  EXPECT_EQ(seed, 3);
  double lr = 0;
  c.child("train").get("lr", lr);
  EXPECT_DOUBLE_EQ(lr, 0.001);  // untouched
}

TEST(ConfigOverrides, TypedValuesAndTheRecordedTextLoadBackTheSame) {
  auto c = ConfigNode::fromString("model:\n  k1: 5  # neighbours\ntrain:\n  lr: 0.001\n", "o.yaml");
  // A folder name that `--set data.dir=...` would parse as a YAML map, not as text.
  setValue(c, "data.dir", YAML::Node("runs/a: b"));
  setValue(c, "train.threads", YAML::Node(3));
  const std::string text = toYamlText(c);
  const auto back = ConfigNode::fromString(text, "recorded.yaml");
  std::string dir;
  int k1 = 0, threads = 0;
  double lr = 0.0;
  back.child("data").get("dir", dir);
  back.child("model").get("k1", k1);
  back.child("train").get("threads", threads);
  back.child("train").get("lr", lr);
  EXPECT_EQ(dir, "runs/a: b");
  EXPECT_EQ(k1, 5);
  EXPECT_EQ(threads, 3);
  EXPECT_DOUBLE_EQ(lr, 0.001);
  EXPECT_THROW(setValue(c, "model.k1.x", YAML::Node(1)), ConfigError);
}

TEST(ConfigOverrides, BadAssignmentsNameTheAssignment) {
  auto c = ConfigNode::fromString("model:\n  k1: 5\n", "o.yaml");
  for (const std::string bad : {"model.k1", "=3", "model..k1=3", "model.k1.x=3", "model.k1=[1,"}) {
    try {
      applyOverride(c, bad);
      FAIL() << bad;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  int k1 = 0;
  c.child("model").get("k1", k1);
  EXPECT_EQ(k1, 5);  // failed overrides change nothing
}

TEST(Config, FuzzFindingAMapUsedAsAKeyIsAConfigError) {
  // Found by tests/fuzz (scripts/fuzz.sh): "{{}: ...}" — YAML allows a map as a key. checkKeys
  // converted every key to text and let yaml-cpp's bad-conversion exception escape; it must be a
  // ConfigError naming the file.
  for (const char* text : {"{{}: 1}", "[1, 2]: x\n", "a: 1\n? {b: 2}\n: 3\n"}) {
    const auto node = ConfigNode::fromString(text, "bad.yaml");
    try {
      node.checkKeys({"a"});
      ADD_FAILURE() << "no error for " << text;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  }
}

TEST(Config, ATextFileOrAListIsNotAConfiguration) {
  // A plain-text file given as a configuration parses as one YAML scalar; a tool must not run on
  // defaults from it.
  try {
    ConfigNode::fromString("my-laptop\n", "/etc/hostname").checkKeys({"model", "train"});
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/etc/hostname"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("expected a map"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ConfigNode::fromString("- a\n- b\n", "l.yaml").checkKeys({"a"}), ConfigError);
  EXPECT_THROW(ConfigNode::fromString("train: 3\n", "s.yaml").child("train").checkKeys({"lr"}),
               ConfigError);
  // Empty files and absent sections have no key to check.
  EXPECT_NO_THROW(ConfigNode::fromString("", "e.yaml").checkKeys({"a"}));
  EXPECT_NO_THROW(ConfigNode::fromString("a: 1\n", "m.yaml").child("b").checkKeys({"x"}));
}
