// Replays a fuzz target's corpus without libFuzzer (the tests run it with the
// normal build): every file under the given directories goes through the
// target once. `--write-seeds DIR` writes the target's seeds there first.
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>

#include "fuzz_target.hpp"

int main(int argc, char** argv) {
  namespace fs = std::filesystem;
  std::size_t inputs = 0;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--write-seeds" && i + 1 < argc) {
      const fs::path dir = argv[++i];
      fs::create_directories(dir);
      int n = 0;
      for (const auto& seed : cosim::fuzz::seeds())
        std::ofstream(dir / ("seed-" + std::to_string(n++)), std::ios::binary)
            .write(reinterpret_cast<const char*>(seed.data()), static_cast<std::streamsize>(seed.size()));
      continue;
    }
    if (!fs::is_directory(arg)) {
      std::cerr << argv[0] << ": '" << arg << "' is not a corpus directory\n";
      return 2;
    }
    for (const auto& entry : fs::recursive_directory_iterator(arg)) {
      if (!entry.is_regular_file()) continue;
      std::ifstream in(entry.path(), std::ios::binary);
      const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
      LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size());
      ++inputs;
    }
  }
  std::cout << "replayed " << inputs << " inputs\n";
  return inputs > 0 ? 0 : 1;
}
