// Fuzz target: message-definition texts, mutated from the definitions in
// the source tree. Each is parsed as a client's put_message_definition
// would be (md::Library::load_text, then sizes, signature and the C header
// emitter); it must load or fail with md::Error, never anything else. Some
// go through a running manager too, which must serve a normal client after.
#include <dirent.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "fuzz.hpp"
#include "generate/c_header.hpp"
#include "ln/md/message_definition.hpp"
#include "manager/request_error.hpp"
#include "manager/test_support.hpp"

namespace ln::fuzz {
namespace {

using namespace manager::testing;  // the manager's test support: TempDir, RunningManager, TestClient
using protocol::Message;

void collect_files(const std::string& dir, std::vector<std::string>& texts) {
  DIR* handle = ::opendir(dir.c_str());
  if (handle == nullptr) return;
  while (const dirent* entry = ::readdir(handle)) {
    const std::string name = entry->d_name;
    if (name == "." || name == "..") continue;
    const std::string path = dir + "/" + name;
    struct stat st;
    if (::stat(path.c_str(), &st) != 0) continue;
    if (S_ISDIR(st.st_mode)) {
      collect_files(path, texts);
    } else if (S_ISREG(st.st_mode) && st.st_size < 65536) {
      std::ifstream in(path, std::ios::binary);
      std::ostringstream content;
      content << in.rdbuf();
      texts.push_back(content.str());
    }
  }
  ::closedir(handle);
}

std::vector<std::string> corpus_texts() {
  std::vector<std::string> texts;
  for (const char* dir : {"/share/message_definitions", "/src/services/testdata/md", "/examples/elevator/msgdefs",
                          "/python/tests/msgdefs", "/tests/topics/msgdefs"})
    collect_files(std::string(LN_FUZZ_SOURCE_ROOT) + dir, texts);
  // What the grammar allows beyond the files: count expressions, aliases,
  // the other kinds, comments and blanks everywhere.
  texts.push_back("int count\nfloat32_t v[3*4+(2-1)]\nshort s[ 0x10 ]\nchar* text   # a comment\n");
  texts.push_back("event\nconnect\nuint8_t* data\ncall\nfloat64_t t\n");
  texts.push_back("service\nrequest\ndefine p as \"pt\"\np* points\nresponse\nuint32_t points_len\np best\n");
  return texts;
}

// Everything a consumer computes from a definition that loaded.
void use(const md::Definition& def) {
  (void)md::packet_size(def);
  (void)md::signature(def);
  (void)md::struct_layout(def.fields);
  (void)generate::emit_c_header({&def}, generate::CHeaderOptions());
}

TEST(FuzzDefinitionTexts, ParseOrClearError) {
  const std::vector<std::string> corpus = corpus_texts();
  ASSERT_GT(corpus.size(), 10u) << "no definitions found below " << LN_FUZZ_SOURCE_ROOT;
  TempDir dir;
  dir.write("md/fuzz/pt", "double x\ndouble y\n");
  dir.write("md/fuzz/nested", "define pt as \"pt\"\npt a[2]\nuint8_t* raw\n");
  RunningManager running(dir);
  TestClient putter(running.port());
  ASSERT_FALSE(putter.hello("putter").is_error());
  Mutator mutator(seed());
  int loaded = 0;
  Budget budget(100000);
  while (budget.next()) {
    const std::string text = mutator.mutate(corpus[mutator.below(corpus.size())], corpus);
    md::Library library(md::SearchPath::exactly({dir.path() + "/md"}));
    try {
      use(library.load_text("fuzz/case", text));
      ++loaded;
    } catch (const md::Error&) {
      // a clear refusal is fine
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not an md::Error: " << e.what() << " (seed " << seed() << ")\n" << text;
    }
    if (mutator.chance(20)) {
      const Message r = putter.call("put_message_definition", [&](Message& m) {
        m.set("name", "fuzz/put" + std::to_string(mutator.below(8))).set("text", text);
      });
      EXPECT_TRUE(!r.is_error() || r.error_code() != LNE_INTERNAL_ERROR) << r.error_text();
    }
  }
  EXPECT_GT(loaded, 0) << "no mutated text loaded: the mutations are too coarse";
  std::printf("[fuzz] definition texts: %d rounds, %d loaded, seed %llu\n", budget.done(), loaded,
              static_cast<unsigned long long>(seed()));
  TestClient normal(running.port());
  ASSERT_FALSE(normal.hello("normal").is_error());
  const Message stored = normal.call("put_message_definition", [](Message& m) {
    m.set("name", "fuzz/after").set("text", "define pt as \"fuzz/pt\"\npt p\nint32_t n\n");
  });
  ASSERT_FALSE(stored.is_error()) << stored.error_text();
  EXPECT_EQ(
      normal.call("get_message_definition", [](Message& m) { m.set("name", "fuzz/after"); }).get_int("message_size"),
      20);
}

}  // namespace
}  // namespace ln::fuzz
