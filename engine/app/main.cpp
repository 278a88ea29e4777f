#include <iostream>
#include <string>
#include <vector>

#include "engine/app/cli.h"

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  return nucleon::runCommandLine(args, std::cout, std::cerr);
}
