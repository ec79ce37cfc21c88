-- `dca run FILE.dca`: checks the system, starts its hosts' daemons (or uses a hosts file), the root DCAS
-- in this process, brings the tree up (start, connect, confirm), runs it and reports every transition.
-- Exit code: 0 when the root expression ends DONE, 1 when it ends ABORTED (with the path and reason),
-- 2 on bad usage or check errors, 3 when the start fails, 130 after Ctrl-C.
local hosts_mod, args_mod = require "dca.launch.hosts", require "dca.cli.args"

local M = {}

local ipairs, tostring, tonumber, type, sformat = ipairs, tostring, tonumber, type, string.format

M.summary = "run a .dca system: start its hosts and supervisor tree, run it, report each transition"
M.usage = [=[usage: dca run FILE.dca [--root NAME] [--hosts FILE] [--repl] [--watch] [--timeout S] [--quiet]
                    [--config FILE | --no-config] [--set KEY=VALUE]... [--state-dir DIR]
                    [--placement process|group|host]
                    [--sim WORLD [--world-opt KEY=VALUE]... [--seed N] [--record FILE.mcap|FILE.csv] [--realtime]
                    [--tick-timeout MS] [--spin auto|off|US] [--world-host HOST]
                    [--record-ports all|PATH.PORT,...] [--record-compression zstd|lz4|none]
                    [--record-split SIZE|DURATION] [--profile ros2] [--trace FILE]]
                    [--replay REC.mcap [--replay-ports PATTERN,...]]
                    [--blackbox SECONDS_BEFORE,SECONDS_AFTER[,MIB] [--blackbox-storm CLAMPS,SECONDS]]
                    [--driver 'TYPE(HOST, ARGS...)'] [--record FILE.mcap]
                    [--monitor [ADDR] [--monitor-wait] [--as-fast-as-possible] [--monitor-taps all|picked]]

Checks FILE.dca (errors stop here, nothing is started), starts one local daemon per host name on 127.0.0.1
(or uses the daemons named in --hosts, lines of "name address"), starts the supervisor tree, shows one line
per group as it comes up and one per process transition, and runs the root expression.
  --root NAME     the root process (default: main)
  --hosts FILE    daemons already running: "name address" per line
  --config FILE   the system's configuration defaults (`key = value` lines, literals): the keys the
                  repository lacks are written to it before the start (default: FILE.config beside
                  FILE.dca, when there is one); a parameter config("key") reads the repository of its host
  --no-config     no defaults file
  --set KEY=VALUE write KEY into the repository before the start, whatever it holds (repeatable)
  --state-dir DIR the local daemons keep their repositories in DIR/<host> and find them there next time
                  (default: a fresh directory for this run, removed at the end)
  --placement P   where the leaves run: `process` (the default on the wall clock) each in its own `dca node`
                  process, so a crash ends that leaf only; `group` the leaves of one group on one host in
                  one shared node; `host` (the default with --sim or --replay) every leaf on one host in one
                  shared node. Leaves that share a node exchange samples in process and take one lock-step
                  advance per tick; a crash of a shared node ends each of its leaves; a restart of a leaf
                  whose package changed on disk moves it to a process of its own (docs/placement.md). The
                  outcome is the same.
  --sim WORLD     run in simulated time: FILE.dca's device ports checked against WORLD's signals (a world
                  plug-in's name, `dca sim --worlds`; ROBOT.urdf, mock:ROBOT.urdf: docs/robots.md; without
                  --sim, the default world's, as `dca check`), the daemons on the simulated clock, the world
                  (`dca sim --serve --world WORLD`) started through the first host's daemon before the tree,
                  its device ports wired to the leaves that have them, time started when the root runs; the
                  lines carry the simulated time and the end prints the world's summary (simulated and wall
                  time, each step's start and end, and what the world's report adds: docs/worlds.md)
  --world-opt KEY=VALUE  one of the world's own options, checked before anything starts (repeatable; a
                  flag alone: --world-opt KEY), e.g. --world-opt door_width=0.9 --world-opt jammed
  --seed N, --record FILE.mcap|FILE.csv   passed to the world (see `dca sim --help`)
  --record FILE.mcap  without --sim (a --driver run, or daemons without a simulator): written by the run
                  on the wall clock: its lines (/dca/events, /dca/log) and, for each leaf on a real-time
                  thread, its figures there every second and at the end (/dca/rt/PATH; docs/recording.md)
  --driver 'TYPE(HOST, ARGS...)'
                  run against a robot's driver in wall-clock time instead of a simulated world: the controller
                  TYPE (written and checked as an instance in a .dca file: pkg.Type for a package's) started in
                  `dca node --name world` on HOST before the tree and stopped after it; its ports are the
                  robot's signals, checked against the leaves' device ports and wired to them
                  (docs/drivers.md)
  --record-ports all|PATH.PORT,...
                  with --record FILE.mcap: the samples of these output ports (every leaf's with `all`, e.g.
                  main.dooropensyst.dooropen.visualserv.Vel) recorded too, one channel per port
                  (/main/.../Vel, JSON with its JSON Schema), each sample at the tick its leaf wrote it: taps
                  into the world, which is in lock-step, so the recording is exact and the run unchanged
                  (the world's outputs too, as published: what --replay serves again)
  --record-compression zstd|lz4|none
                  with --record FILE.mcap: how its chunks are compressed (default zstd: about 5 to 10 times
                  smaller at a small cost, tests/bench/RESULTS.md "Recording"; lz4 writes faster, shrinks less)
  --record-split SIZE|DURATION
                  with --record FILE.mcap: FILE-000.mcap, FILE-001.mcap, ... instead, a new file once one holds
                  about SIZE (100MB, 1GiB) or every DURATION of simulated time (60s, 10min, 1h); each file is a
                  whole MCAP recording with every channel
  --profile ros2  with --record FILE.mcap: the MCAP `ros2` profile (what rosbag2 writes): the message ports'
                  channels (--record-ports) hold each sample's CDR with its ros2msg schema, so `ros2 bag play`
                  replays them; the other channels stay JSON (docs/recording.md, "The ros2 profile")
  --replay REC.mcap
                  run against a recording instead of a simulator (--sim replay:REC.mcap, no physics): the
                  world's outputs recorded by `--record REC.mcap --record-ports ...` served at their recorded
                  ticks, every controller live; record this run too and `dca trace diff REC.mcap NEW.mcap`
                  names the first tick and port where a live output differs from the recording (a trace
                  with --trace compares as well)
  --replay-ports PATTERN,...
                  with --replay: these controller outputs written again from the recording at their recorded
                  ticks, in place of their live writers (cut from the inputs they feed; still recorded): a
                  port PATH.PORT, a leaf or a group (all their outputs), `*` any text, `world` the world's
                  signals (always from the file under --replay); each must be recorded with numbers
  --blackbox B,A[,MIB]
                  with --record FILE.mcap: a black box instead of the whole recording: what it would write
                  held for the last B seconds (at most MIB MiB, default 64) and written, with A seconds
                  after, to FILE-1.mcap, FILE-2.mcap, ... when a process aborts, crashes or is lost, or
                  a group exceeds its restart intensity; the file names its trigger on /dca/blackbox and
                  holds the run's lines; also triggered by the first refusal of a second writer on a
                  command input, a storm of limit clamps, `blackbox(WHY)` in the REPL, the monitor's
                  "black box" button and SIGUSR2 to dca run
  --blackbox-storm CLAMPS,SECONDS
                  with --blackbox: a storm is CLAMPS command samples clamped to the robot's limits within
                  SECONDS of simulated time (default 10,1), a trigger once per storm
  --realtime      passed to the world: simulated time is paced to the wall clock (the nodes stay in
                  lock-step with it), so the wall-clock periods in the summary are the real control periods
  --world-host HOST  the host whose daemon starts the world (default the first host name in sorted order):
                  the robot's own computer, where its driver would run
  --tick-timeout MS  passed to the world: how long a node may take to answer an advance before the clock
                  drops it (default 10000; under about 2000 the supervisors are dropped too: docs/time.md)
  --spin auto|off|US  passed to the world: after answering an advance a node polls for the next one for US
                  µs instead of sleeping, and the world for the answers (auto, the default: 2000 while
                  every process on the clock has a CPU of its own; docs/time.md "Spinning")
  --trace FILE    write the run's trace (simulated time): every output's samples per tick (count, digest,
                  value), every set switch, event and transition with its tick; `dca trace diff A B` gives
                  the first divergence of two (ARCHITECTURE.md "Time")
  --monitor [ADDR] serve the web monitor from the root (default 127.0.0.1:0, a free port) and print its
                  address with its token: the tree, the expressions, the timeline, live plots, the
                  configuration; without the token the page shows nothing and changes nothing. The same
                  port speaks Foxglove's WebSocket protocol (printed: foxglove: ws://ADDR/?token=T): every
                  port and world signal a channel
  --monitor-taps all|picked  with --monitor: every port and world signal tapped from the start, each kept
                  from t = 0 (bounded and decimated) so a plot picked late, or after the end, shows the
                  whole run (all, the default); or each tapped only when first picked or subscribed to
  --monitor-wait  with --sim: simulated time starts only once a monitor page is connected
  --as-fast-as-possible  with --monitor and --sim: simulated time runs as fast as the nodes allow. Without it,
                  --monitor paces simulated time to the wall clock (1x), so a run can be followed live; the
                  page and the REPL pause it, step it (one tick, or to the next event) and set its speed
                  (0.1x to 10x, or max: unpaced) through the world, the clock master (docs/time.md "Pace")
  --repl          open a console on the root supervisor once the system runs
  --watch         reload the system file when it is saved (inotify)
  --timeout S     stop with an error when the start does not finish within S seconds (default 30)
  --quiet         no progress lines; only the outcome
Exit code 0 when the root expression ends DONE, 1 when ABORTED, 2 for usage or check errors, 3 when the
start fails, 130 after Ctrl-C. Ctrl-C stops the whole tree, most recently started first.]=]

--- The values of --placement (dca.supervisor.net).
M.PLACEMENTS = { process = true, group = true, host = true }

local OPTIONS = {
  ["--root"] = "value", ["--hosts"] = "value", ["--sim"] = "value", ["--seed"] = "number",
  ["--world-opt"] = "list:world_opts", ["--record"] = "value", ["--realtime"] = "flag",
  ["--timeout"] = "number", ["--repl"] = "flag", ["--watch"] = "flag", ["--quiet"] = "flag",
  ["--config"] = "value", ["--no-config"] = "flag", ["--state-dir"] = "value", ["--set"] = "list:sets",
  ["--placement"] = "value", ["--trace"] = "value", ["--monitor"] = "flag", ["--monitor-wait"] = "flag",
  ["--as-fast-as-possible"] = "flag", ["--monitor-taps"] = "value",
  ["--record-ports"] = "value", ["--driver"] = "value", ["--replay"] = "value",
  ["--blackbox"] = "value", ["--replay-ports"] = "value",
  ["--blackbox-storm"] = "value", ["--tick-timeout"] = "number", ["--world-host"] = "value",
  ["--spin"] = "value",
  ["--record-compression"] = "value", ["--record-split"] = "value", ["--profile"] = "value",
}

-- `--monitor ADDR`: the address, when the argument after --monitor is one (else --monitor alone). --> argv
local function monitor_address(args)
  local out, n = {}, args.n or #args
  local i = 1
  while i <= n do
    out[#out + 1] = args[i]
    if args[i] == "--monitor" and type(args[i + 1]) == "string" and args[i + 1]:match("^[%w%.%-%[%]:]*:%d+$") then
      out.monitor_addr = args[i + 1]
      i = i + 1
    end
    i = i + 1
  end
  out.n = #out
  return out
end

-- The options that exclude each other or need another: the first broken rule. --> error text | nil
local function rule_broken(o)
  if not o.file then return "which .dca file?" end
  if (o.seed or o.world_opts) and not o.sim then return "--seed and --world-opt go with --sim WORLD" end
  if o.record and not o.sim and not o.record:match("%.mcap$") then
    return "--record FILE.csv goes with --sim WORLD (on the wall clock a recording is FILE.mcap)"
  end
  -- on the wall clock the run writes the recording itself: no world to tap ports into in lock-step
  if o.record_ports and not o.sim then
    return "--record-ports goes with --sim WORLD: on the wall clock (--driver, or no --sim) a recording holds " ..
      "the run's lines and the real-time figures only (docs/recording.md)"
  end
  if o.blackbox and not o.sim then return "--blackbox goes with --sim WORLD" end
  if o.trace and not o.sim then return "--trace goes with --sim WORLD"
  end
  if o.record_ports and not (o.record and o.record:match("%.mcap$")) then
    return "--record-ports goes with --record FILE.mcap"
  end
  if o.replay_ports and not o.replay then return "--replay-ports goes with --replay REC.mcap" end
  if o.blackbox and not (o.record and o.record:match("%.mcap$")) then
    return "--blackbox goes with --record FILE.mcap"
  end
  if o.blackbox_storm and not o.blackbox then return "--blackbox-storm goes with --blackbox" end
  if (o.record_compression or o.record_split) and not (o.record and o.record:match("%.mcap$")) then
    return "--record-compression and --record-split go with --record FILE.mcap"
  end
  if o.record_compression and not ({ zstd = true, lz4 = true, none = true })[o.record_compression] then
    return "--record-compression is zstd, lz4 or none, not '" .. tostring(o.record_compression) .. "'"
  end
  if o.profile and not (o.record and o.record:match("%.mcap$") and o.sim) then
    return "--profile goes with --sim WORLD and --record FILE.mcap (on the wall clock no message port is recorded)"
  end
  if o.profile and o.profile ~= "ros2" then return "--profile is ros2, not '" .. tostring(o.profile) .. "'" end
  if o.record_split and o.blackbox then return "--record-split and --blackbox exclude each other" end
  local split_units = { [""] = true, B = true, KB = true, MB = true, GB = true, KiB = true, MiB = true, GiB = true,
                        s = true, min = true, h = true }
  if o.record_split and not split_units[o.record_split:match("^%d+%.?%d*(%a*)$") or "?"] then
    return "--record-split needs a size (100MB, 1GiB) or a duration (60s, 10min, 1h), not '" .. o.record_split .. "'"
  end
  if o.config and o.no_config then return "--config and --no-config exclude each other" end
  if o.driver and o.sim then return "--driver and --sim exclude each other: a driver is the robot" end
  if o.state_dir and o.hosts then return "--state-dir is for the local daemons, not those of --hosts" end
  if o.realtime and not o.sim then return "--realtime goes with --sim WORLD" end
  if o.tick_timeout and not (o.sim and o.tick_timeout >= 1 and o.tick_timeout <= 3600000) then
    return "--tick-timeout goes with --sim WORLD and takes milliseconds from 1 to 3600000"
  end
  if o.spin then
    local us = tonumber(o.spin)
    if not o.sim or not (o.spin == "auto" or o.spin == "off" or (us and us % 1 == 0 and us >= 1
        and us <= 100000)) then
      return "--spin goes with --sim WORLD and takes auto, off or microseconds from 1 to 100000"
    end
  end
  if o.world_host and not o.sim then return "--world-host goes with --sim WORLD" end
  if o.monitor_wait and not (o.monitor and o.sim) then return "--monitor-wait goes with --monitor and --sim WORLD" end
  if o.as_fast_as_possible and not (o.monitor and o.sim) then
    return "--as-fast-as-possible goes with --monitor and --sim WORLD (without --monitor time is unpaced already)"
  end
  if o.monitor_taps and not (o.monitor and (o.monitor_taps == "all" or o.monitor_taps == "picked")) then
    return "--monitor-taps goes with --monitor and is all or picked, not '" .. tostring(o.monitor_taps) .. "'"
  end
  if o.as_fast_as_possible and o.realtime then return "--as-fast-as-possible and --realtime exclude each other" end
  if o.placement and not M.PLACEMENTS[o.placement] then
    return "--placement is process, group or host, not '" .. tostring(o.placement) .. "'"
  end
end

--- The options of argv. --> o | nil, error text
local function parse_args(args)
  args = monitor_address(args)
  local o, err = args_mod.parse(args, "dca run", OPTIONS)
  if not o then return nil, err end
  if o.monitor and args.monitor_addr then o.monitor = args.monitor_addr end
  o.file, o.timeout = o[1], o.timeout or 30
  for _, a in ipairs(o.sets or {}) do
    local k, v = require("dca.config").parse_assignment(a)
    if not k then return nil, "dca run: --set: " .. v end
    o.set = o.set or {}
    o.set[k] = v
  end
  if o.replay and o.sim then return nil, "dca run: --replay and --sim exclude each other: the recording is the world" end
  if o.replay then o.sim = "replay:" .. o.replay end
  local broken = rule_broken(o)
  if broken then return nil, "dca run: " .. broken end
  -- in simulated time the leaves of a host share one node unless asked otherwise (docs/placement.md)
  if o.sim and not o.placement then o.placement = "host" end
  o.record_outputs = o.record_ports and true or nil
  -- watched live, simulated time is paced to the wall clock (1x) unless asked otherwise (docs/time.md "Pace")
  if o.monitor and o.sim and not o.as_fast_as_possible then o.realtime = true end
  o.record_profile = o.profile
  for _, k in ipairs({ "record", "trace" }) do
    if o[k] and o[k]:sub(1, 1) ~= "/" then o[k] = (os.getenv("PWD") or ".") .. "/" .. o[k] end
  end
  if o.trace then o.trace_file, o.trace = o.trace, o.trace .. ".world" end
  return o
end

-- The terminal of a run: stdout for its lines, stderr for its outcome and errors, `dca repl` on /dev/tty; in
-- colour on a terminal (dca.cli.colour: NO_COLOR turns it off).
local colour = require "dca.cli.colour"
local function painted(fd) if colour.on(fd) then return colour.line end return function(t) return t end end
local OUT = {
  line = function(text) io.stdout:write(painted(1)(text), "\n") io.stdout:flush() end,
  outcome = function(text) io.stderr:write(painted(2)(text), "\n") end,
  error = function(text) io.stderr:write("dca run: ", text, "\n") end,
}

--- Starts `dca repl ADDRESS` in its own process on this terminal. --> its pid | nil
function OUT.console(exe, address, key)
  local argv = { exe, "repl", address }
  if key then argv[#argv + 1] = "--key" argv[#argv + 1] = key end
  return (require("dca.core").spawn(argv, { stdin = "/dev/tty", stdout = "/dev/tty" }))
end

function M.main(args)
  local o, perr = parse_args(args)
  if not o then return args_mod.usage_error(perr, M.usage) end
  -- the world's own options checked before anything starts (the world itself is, with the system, below)
  if o.world_opts then
    local ok, werr = require("dca.worlds").check(o.sim, o.world_opts)
    if not ok then io.stderr:write("dca run: --world-opt: ", tostring(werr), "\n") return 2 end
  end
  -- the device ports are held to the world of the run (without --sim: the default world's, as `dca check`), or
  -- to the ports of its driver
  local world = o.sim
  if o.driver then
    local d, derr = require("dca.launch.driver").read(o.driver, o.file)
    if not d then io.stderr:write("dca run: ", derr, "\n") return 2 end
    o.driver, world = d, d.signals
  end
  local spec, err = require("dca.load").spec(o.file, { root = o.root, world = world })
  if not spec then io.stderr:write(err, "\n") return 2 end
  if o.world_host then
    local names = require("dca.supervisor.spec").hosts(spec)
    local known = false
    for _, h in ipairs(names) do known = known or h == o.world_host end
    if not known then
      io.stderr:write(sformat("dca run: --world-host %s is not a host of %s (%s)\n", o.world_host, o.file,
        table.concat(names, ", ")))
      return 2
    end
  end
  o.config = o.config or (not o.no_config and require("dca.config").defaults_file(o.file)) or nil
  -- a defaults file that does not read stops the run here, before any daemon starts
  if o.config then
    local defaults, derr = require("dca.config").read_file(o.config)
    if not defaults then io.stderr:write("dca run: ", derr, "\n") return 2 end
  end
  if o.record_ports then
    -- the ports named must exist before anything starts (the manifests of the file's packages are loaded)
    local ok, terr = require("dca.supervisor.taps").select(spec, require("dca.core").types(), o.record_ports)
    if not ok then io.stderr:write("dca run: --record-ports: ", terr, "\n") return 2 end
  end
  if o.replay_ports then
    -- the outputs named must exist and be in the recording before anything starts
    local rp = require "dca.launch.replay_ports"
    local paths, rerr = rp.select(spec, require("dca.core").types(), o.replay_ports)
    local ok = paths ~= nil
    if ok then ok, rerr = rp.check(paths, o.replay) end
    if not ok then io.stderr:write("dca run: --replay-ports: ", rerr, "\n") return 2 end
    rp.mark(spec, paths)
  end
  o.check, o.summary, o.wait = true, true, o.timeout
  return require("dca.launch.run").main(spec, o, OUT)
end

return M
