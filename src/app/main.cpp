#include <fcntl.h>
#include <malloc.h>
#include <signal.h>
#include <unistd.h>

#include <cerrno>

#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "app/commands.hpp"
#include "core/error.hpp"
#include "core/log.hpp"
#include "core/suggestion.hpp"

namespace {

// " (did you mean --max-error?)" for the first unknown flag given to the
// command that was parsed, when a flag of it is within a typo; else "".
std::string flagSuggestion(CLI::App& cli) {
  // A flag the command does not know falls through to the top level (see
  // fallthrough below) and is compared with the command's flags and the top
  // level's.
  const std::vector<CLI::App*> commands = cli.get_subcommands();
  std::vector<std::string> names;
  for (CLI::App* app : {commands.empty() ? &cli : commands.front(), &cli}) {
    for (const CLI::Option* option : app->get_options()) {
      for (const std::string& name : option->get_lnames()) names.push_back("--" + name);
    }
  }
  for (const std::string& arg : cli.remaining(true)) {
    if (arg.rfind("--", 0) != 0) continue;
    const std::string best = terrabake::nearestName(arg.substr(0, arg.find('=')), {names.begin(), names.end()});
    return best.empty() ? "" : " (did you mean " + best + "?)";
  }
  return "";
}

// "'bogus' is not a command ..." when the first word left over is where a
// command belongs; else "".
std::string unknownCommand(CLI::App& cli) {
  const std::vector<std::string> left = cli.remaining();
  if (left.empty() || left.front().rfind('-', 0) == 0 || !cli.get_subcommands().empty()) return "";
  std::vector<std::string> names;
  for (const CLI::App* command : cli.get_subcommands({})) names.push_back(command->get_name());
  std::string list;
  for (const std::string& name : names) list += (list.empty() ? "" : ", ") + name;
  const std::string best = terrabake::nearestName(left.front(), {names.begin(), names.end()});
  return "'" + left.front() + "' is not a command (" + list + ")" +
         (best.empty() ? "" : "; did you mean " + best + "?");
}

// "--workers is given 2 times; ..." for a flag that takes one value and was
// given more than once; else "".
std::string repeatedFlag(CLI::App& cli) {
  std::vector<CLI::App*> apps = cli.get_subcommands();
  apps.push_back(&cli);
  for (CLI::App* app : apps) {
    for (const CLI::Option* option : app->get_options()) {
      if (option->count() > 1 && option->get_multi_option_policy() == CLI::MultiOptionPolicy::Throw) {
        return option->get_name() + " is given " + std::to_string(option->count()) + " times; give it once";
      }
    }
  }
  return "";
}

// Opens /dev/null on any of standard input, output and error that is closed,
// so that no file the run opens later takes their numbers: a pipe or a tile
// file there would receive the log.
void openClosedStandardStreams() {
  for (int fd = 0; fd <= 2; ++fd) {
    if (::fcntl(fd, F_GETFD) != -1 || errno != EBADF) continue;
    const int null = ::open("/dev/null", fd == 0 ? O_RDONLY : O_WRONLY);
    // open takes the lowest free number, which is fd; anything else is not ours to keep.
    if (null != fd && null >= 0) ::close(null);
  }
}

}  // namespace

int main(int argc, char** argv) {
  using namespace terrabake;
  openClosedStandardStreams();
  // A reader that went away (`terrabake info ... | head -1`) and a file
  // larger than ulimit -f allows make writes fail with an error the writer
  // reports (a tile's log lines cost, a full output stops the run, exit 3),
  // instead of ending the process.
  ::signal(SIGPIPE, SIG_IGN);
  ::signal(SIGXFSZ, SIG_IGN);
  // A tile's buffers (sample grids, meshes, images: 0.1 to 10 MiB each) are
  // made and freed for every tile. Kept on the heap rather than mapped and
  // unmapped each time, they cost no fresh pages: measured on 324 tiles, the
  // system time falls from 2.1 s to 0.5 s, a tenth of the run.
  mallopt(M_MMAP_THRESHOLD, 64 << 20);
  mallopt(M_TRIM_THRESHOLD, 256 << 20);
  CLI::App cli("terrabake: seamless tangent-space normal-map tiles and low-poly glTF meshes from a DEM",
               "terrabake");
  cli.footer(app::kExitCodes);
  cli.require_subcommand(1);
  cli.set_version_flag("--version", "terrabake " TERRABAKE_VERSION, "Print the version and exit");
  bool verbose = false;
  cli.add_flag("-v,--verbose", verbose, "Log debug detail: GDAL's warnings, each on-demand bake");
  // -v may also follow the subcommand (terrabake tile -v ...): the
  // subcommands made after this pass flags they do not know up to here.
  cli.fallthrough();
  const app::Action tile = app::addTileCommand(cli);
  const app::Action serve = app::addServeCommand(cli);
  const app::Action info = app::addInfoCommand(cli);

  try {
    cli.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    return cli.exit(e);
  } catch (const CLI::CallForAllHelp& e) {
    return cli.exit(e);
  } catch (const CLI::CallForVersion& e) {
    return cli.exit(e);
  } catch (const CLI::ExtrasError& e) {
    std::cerr << "terrabake: error: " << messageLine(e.what()) << flagSuggestion(cli)
              << " (see terrabake --help)\n";
    return int(ExitCode::kUsage);
  } catch (const CLI::ParseError& e) {
    std::string problem = unknownCommand(cli);
    if (problem.empty()) problem = repeatedFlag(cli);
    if (problem.empty()) problem = e.what();
    std::cerr << "terrabake: error: " << messageLine(problem) << " (see terrabake --help)\n";
    return int(ExitCode::kUsage);
  }
  if (verbose) log::setLevel(log::Level::kDebug);

  try {
    if (cli.got_subcommand("serve")) return serve();
    if (cli.got_subcommand("info")) return info();
    return tile();
  } catch (const NothingToMake& e) {
    log::warning(messageLine(e.what()));
    return int(e.code());
  } catch (const RunStoppingError& e) {
    // Before any tile (the layer's record, say): what to do, as a tile's error says it.
    log::error(messageLine(std::string(e.what()) + ": " + e.remedy));
    return int(e.code());
  } catch (const Error& e) {
    log::error(messageLine(e.what()));
    return int(e.code());
  } catch (const std::exception& e) {
    log::error("unexpected: " + messageLine(e.what()));
    return int(ExitCode::kInput);
  }
}
