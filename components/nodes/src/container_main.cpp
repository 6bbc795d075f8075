// ddsnav-container: several stock components in one process, each with its own parameters, names and
// executor thread, passing messages between them as objects (intra-process delivery, docs/bus.md):
//   ddsnav container -- sim --param scenario=S -- perception --name perception --param clock=topic
// A launch file's `container:` entry builds this command line (docs/launch.md).
#include <ddsnav/runtime/component.hpp>

int main(int argc, char** argv) { return ddsnav::runtime::runContainer(argc, argv); }
