#include "cosim/coupler/cli.hpp"

int main(int argc, char** argv) { return cosim::coupler::couplerMain(argc, argv); }
