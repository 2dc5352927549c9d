// The capture status words: one list, read back exactly, an unknown word
// refused by name, and the JavaScript's list the same as the C++ one.
#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "arscout/documents/capture.h"
#include "arscout/documents/capture_status.h"
#include "arscout/documents/document_error.h"

namespace arscout::documents {
namespace {

constexpr CaptureStatus kAll[] = {
    CaptureStatus::kRegistered, CaptureStatus::kPending,
    CaptureStatus::kRejected,   CaptureStatus::kStored,
    CaptureStatus::kNeedsGps,   CaptureStatus::kWithdrawn};

TEST(CaptureStatusWords, ReadBackAndStayTheStoredOnes) {
  std::set<std::string> words;
  for (CaptureStatus s : kAll) {
    EXPECT_EQ(parse_capture_status(to_string(s)), s);
    words.insert(to_string(s));
  }
  // Stored data holds these words: they are never renamed.
  EXPECT_EQ(words, (std::set<std::string>{"registered", "pending", "rejected",
                                          "stored", "needs-gps", "withdrawn"}));
  // The engine state's bytes hold the engine's three as these numbers.
  EXPECT_EQ(static_cast<int>(CaptureStatus::kRegistered), 0);
  EXPECT_EQ(static_cast<int>(CaptureStatus::kPending), 1);
  EXPECT_EQ(static_cast<int>(CaptureStatus::kRejected), 2);
}

TEST(CaptureStatusWords, RefuseAnUnknownWordByName) {
  EXPECT_FALSE(capture_status_of("placed"));
  EXPECT_FALSE(capture_status_of(""));
  try {
    parse_capture_status("placed");
    ADD_FAILURE() << "no error for an unknown word";
  } catch (const DocumentError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("'placed'"), std::string::npos) << what;
    EXPECT_NE(what.find("needs-gps"), std::string::npos) << what;
  }
}

TEST(CaptureStatusWords, PendingIsStoredInTheCapturesDocument) {
  EXPECT_EQ(capture_document_status(CaptureStatus::kPending),
            CaptureStatus::kStored);
  EXPECT_EQ(capture_document_status(CaptureStatus::kRegistered),
            CaptureStatus::kRegistered);
  EXPECT_EQ(capture_document_status(CaptureStatus::kRejected),
            CaptureStatus::kRejected);
}

TEST(CaptureStatusWords, ACaptureWithAnotherVersionsWordHasNone) {
  const Capture c = capture_from_json({{"status", "placed"}});
  EXPECT_FALSE(c.status);
  EXPECT_EQ(to_json(c).at("status"), "");
  EXPECT_EQ(capture_from_json({{"status", "needs-gps"}}).status,
            CaptureStatus::kNeedsGps);
}

// viewer/web/capture_status.js names the words for the JavaScript.
TEST(CaptureStatusWords, AreTheJavaScriptOnes) {
  std::ifstream in(ARSCOUT_SOURCE_DIR "/viewer/web/capture_status.js");
  ASSERT_TRUE(in) << "viewer/web/capture_status.js";
  std::stringstream text;
  text << in.rdbuf();
  const std::string js = text.str();
  const std::regex entry(R"(\n  [A-Z_]+: '([a-z-]+)',)");
  std::set<std::string> named;
  for (std::sregex_iterator it(js.begin(), js.end(), entry), end; it != end;
       ++it)
    named.insert((*it)[1]);
  std::set<std::string> words;
  for (CaptureStatus s : kAll) words.insert(to_string(s));
  EXPECT_EQ(named, words);
}

}  // namespace
}  // namespace arscout::documents
