// Fuzz target: .lnc configuration files, through the reader's public entry
// point (manager/config.hpp read_lnc_file): mutated from configs that use
// every construct the reader knows and many it reports. A config must be
// read or refused with a ConfigError (FILE:LINE: reason), never anything
// else; then a manager started from a valid config serves a client.
#include <gtest/gtest.h>

#include <cstdio>

#include "fuzz.hpp"
#include "manager/config.hpp"
#include "manager/test_support.hpp"

namespace ln::fuzz {
namespace {

using manager::testing::TempDir;
using manager::testing::TestClient;

std::vector<std::string> corpus_texts() {
  return {
      "instance\nname: fuzzed\nmanager: 127.0.0.1:0\ngen_message_definition_path: %(CURDIR)/gen\n"
      "max_topic_shm: 64M\nhandshake_timeout: 2.5\nmax_pending_per_peer: 16\n\n"
      "defines\nroot: %(CURDIR)\nport: %(get_port_from_string %(instance_name))\nhome: %(env HOME)\n\n"
      "add_message_definition_dir %(root)/md\n",
      "defines\na: 1\nb: %(a)%(a)\nname: %(strip  spaced  )\n\ninstance\nname: %(b)_%(hostname)\n"
      "ifdef a add_message_definition_dir /tmp\nifndef zz warning no zz here\nundef a\n",
      "include part.lnc\noptional_include missing.lnc\ninstance\nname: %(from_part)\n",
      "instance\nname: x\n\nprocess demo\ncommand: /bin/true\nnode: localhost\nstate: UP\n\n"
      "state UP\ncheck_command: true\n\ngroup g\nmembers: demo\n\nhosts\nlocalhost: 127.0.0.1\n",
      "# comment\ninstance\nname: %(dirname /a/b/c)/%(basename /a/b/c)/%(realpath .)\n"
      "max_clients: 10\nmax_output_queue: 1k\nmax_stored_definition_bytes: 3G\npending_idle_timeout: 0.25\n",
  };
}

TEST(FuzzLncFiles, ReadOrConfigError) {
  TempDir dir;
  dir.write("part.lnc", "defines\nfrom_part: %(CURDIR)\n");
  dir.write("md/fz/p", "double x\n");
  const std::vector<std::string> corpus = corpus_texts();
  Mutator mutator(seed());
  int read = 0;
  Budget budget(10000);
  while (budget.next()) {
    const std::string path = dir.write("case.lnc", mutator.mutate(corpus[mutator.below(corpus.size())], corpus));
    try {
      (void)manager::read_lnc_file(path, {});
      ++read;
    } catch (const manager::ConfigError& e) {
      EXPECT_EQ(std::string(e.what()).rfind(e.file() + ":", 0), 0u) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << "not a ConfigError: " << e.what() << " (seed " << seed() << ")";
    }
  }
  EXPECT_GT(read, 0);
  std::printf("[fuzz] .lnc files: %d rounds, %d read, seed %llu\n", budget.done(), read,
              static_cast<unsigned long long>(seed()));

  // A manager from a valid config still serves.
  const std::string path = dir.write("good.lnc",
                                     "instance\nname: after_fuzz\nmax_clients: 8\n\nadd_message_definition_dir "
                                     "%(CURDIR)/md\n");
  const manager::LncSettings settings = manager::read_lnc_file(path, {});
  manager::ManagerOptions options;
  options.port = 0;
  options.instance_name = settings.instance_name;
  options.message_definition_dirs = settings.message_definition_dirs;
  options.generated_definition_dir = dir.path() + "/gen";
  options.limits = settings.limits;
  manager::Manager running(options);
  running.start();
  running.run_in_thread();
  TestClient client(running.port());
  ASSERT_FALSE(client.hello("normal").is_error());
  EXPECT_EQ(client.call("get_message_definition", [](protocol::Message& m) { m.set("name", "fz/p"); })
                .get_int("message_size"),
            8);
  running.stop();
}

}  // namespace
}  // namespace ln::fuzz
