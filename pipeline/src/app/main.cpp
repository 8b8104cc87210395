// vim-pipeline: the command-line tool (options and run order in cli.hpp / cli.cpp).
#include <vim/pipeline/app/cli.hpp>

int main(int argc, char** argv) { return vim::pipeline::main_cli(argc, argv); }
