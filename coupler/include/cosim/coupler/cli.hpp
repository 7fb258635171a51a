#pragma once
namespace cosim::coupler {
/// `coupler run|check|sweep ...`: the whole command line; returns the exit code.
int couplerMain(int argc, char** argv);
}  // namespace cosim::coupler
