// The mjstepper program (src/tools/command.h).
#include "command.h"

int main(int argc, char** argv) { return mjstepper::tools::Main(argc, argv); }
