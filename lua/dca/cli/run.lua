-- `dca run FILE.dca`: checks the system, starts its hosts' daemons (or uses a hosts file), the root DCAS
-- in this process, brings the tree up (start, connect, confirm), runs it and reports every transition.
-- Exit code: 0 when the root expression ends DONE, 1 when it ends ABORTED (with the path and reason),
-- 2 on bad usage or check errors, 3 when the start fails, 130 after Ctrl-C.
local core = require "dca.core"
local supervisor = require "dca.supervisor"
local spec_mod = require "dca.supervisor.spec"
local srt = require "dca.supervisor.net"
local hosts_mod = require "dca.launch.hosts"
local sim = require "dca.clients.world"

local M = {}

M.summary = "run a .dca system: start its hosts and supervisor tree, run it, report each transition"
M.usage = [=[usage: dca run FILE.dca [--root NAME] [--hosts FILE] [--repl] [--watch] [--timeout S] [--quiet]
                    [--config FILE | --no-config] [--set KEY=VALUE]... [--state-dir DIR]
                    [--sim WORLD [--seed N] [--door-width W] [--record FILE.csv] [--jammed] [--realtime]]

Checks FILE.dca (errors stop here, nothing is started), starts one local daemon per host name on 127.0.0.1
(or uses the daemons named in --hosts, lines of "name address"), starts the supervisor tree, shows one line
per group as it comes up and one per process transition, and runs the root expression.
  --root NAME     the root process (default: main)
  --hosts FILE    daemons already running: "name address" per line
  --config FILE   the system's configuration defaults (`key = value` lines, Lua literals): the keys the
                  repository lacks are written to it before the start (default: FILE.config beside
                  FILE.dca, when there is one); a parameter config("key") reads the repository of its host
  --no-config     no defaults file
  --set KEY=VALUE write KEY into the repository before the start, whatever it holds (repeatable)
  --state-dir DIR the local daemons keep their repositories in DIR/<host> and find them there next time
                  (default: a fresh directory for this run, removed at the end)
  --sim WORLD     run in simulated time: the daemons on the simulated clock, the world (`dca sim --serve
                  --world WORLD`, e.g. door) started through the first host's daemon before the tree, its
                  device ports wired to the leaves that have them, time started when the root runs; the
                  lines carry the simulated time and the end prints the world's summary (door angle,
                  simulated and wall time, each step's start and end, and the control periods achieved
                  by the leaves of every MotionControl group: intervals between their MainCalc calls on the
                  simulated and on the wall clock, p50/p99/max)
  --seed N, --door-width W, --record FILE.csv   passed to the world (see `dca sim --help`)
  --jammed        passed to the world: the door handle's latch never releases (a fault to test against)
  --realtime      passed to the world: simulated time is paced to the wall clock (the nodes stay in
                  lock-step with it), so the wall-clock periods in the summary are the real control periods
  --repl          open a console on the root supervisor once the system runs
  --watch         reload the system file when it is saved (inotify)
  --timeout S     stop with an error when the start does not finish within S seconds (default 30)
  --quiet         no progress lines; only the outcome
Exit code 0 when the root expression ends DONE, 1 when ABORTED, 2 for usage or check errors, 3 when the
start fails, 130 after Ctrl-C. Ctrl-C stops the whole tree, most recently started first.]=]

local function parse_args(args)
  local o = { timeout = 30 }
  local i, n = 1, args.n or #args
  local function value(name)
    i = i + 1
    if not args[i] then error("dca run: " .. name .. " needs a value", 0) end
    return args[i]
  end
  while i <= n do
    local a = args[i]
    if a == "--root" then o.root = value(a)
    elseif a == "--hosts" then o.hosts = value(a)
    elseif a == "--sim" then o.sim = value(a)
    elseif a == "--seed" then o.seed = tonumber(value(a)) or error("dca run: --seed needs a number", 0)
    elseif a == "--door-width" then o.door_width = tonumber(value(a)) or error("dca run: --door-width needs metres", 0)
    elseif a == "--record" then o.record = value(a)
    elseif a == "--jammed" then o.jammed = true
    elseif a == "--realtime" then o.realtime = true
    elseif a == "--timeout" then o.timeout = tonumber(value(a)) or error("dca run: --timeout needs seconds", 0)
    elseif a == "--repl" then o.repl = true
    elseif a == "--watch" then o.watch = true
    elseif a == "--quiet" then o.quiet = true
    elseif a == "--config" then o.config = value(a)
    elseif a == "--no-config" then o.no_config = true
    elseif a == "--state-dir" then o.state_dir = value(a)
    elseif a == "--set" then
      local k, v = require("dca.config").parse_assignment(value(a))
      if not k then error("dca run: --set: " .. v, 0) end
      o.set = o.set or {}
      o.set[k] = v
    elseif a:sub(1, 1) == "-" or o.file then error("dca run: unexpected argument '" .. a .. "'", 0)
    else o.file = a end
    i = i + 1
  end
  if not o.file then error("dca run: which .dca file?", 0) end
  if (o.seed or o.door_width or o.record or o.jammed) and not o.sim then
    error("dca run: --seed, --door-width, --record and --jammed go with --sim WORLD", 0)
  end
  if o.config and o.no_config then error("dca run: --config and --no-config exclude each other", 0) end
  if o.state_dir and o.hosts then error("dca run: --state-dir is for the local daemons, not those of --hosts", 0) end
  if o.realtime and not o.sim then error("dca run: --realtime goes with --sim WORLD", 0) end
  if o.record and o.record:sub(1, 1) ~= "/" then o.record = (os.getenv("PWD") or ".") .. "/" .. o.record end
  return o
end

--- Reads, parses and checks FILE and builds the spec of its root. --> spec | nil, error text
function M.load(file, root)
  return require("dca.load").spec(file, { root = root })
end

function M.main(args)
  local ok, o = pcall(parse_args, args)
  if not ok then io.stderr:write(o, "\n", M.usage, "\n") return 2 end
  local spec, err = M.load(o.file, o.root)
  if not spec then io.stderr:write(err, "\n") return 2 end

  local t0 = core.now()
  -- consoles following the root's lines; with --repl the console owns the terminal once it follows, and
  -- prints these lines above its prompt (redrawn), so this process no longer writes them itself
  local followers = {}
  local world  -- with --sim: the world process (dca.clients.world)
  local function emit(text)
    if srt.to_followers(followers, text) > 0 and o.repl then return end
    io.stdout:write(text, "\n")
    io.stdout:flush()
  end
  local function say(line, at)
    if world and world.ch then
      -- stamped with the world's time (in order); the transitions are the steps of the summary
      world:stamp(line, function(t, l) if not o.quiet then emit(string.format("[sim %8.3f] %s", t, l)) end end, at)
    elseif not o.quiet then
      emit(string.format("[%7.3f] %s", core.now() - t0, line))
    end
  end

  -- hosts: a file of running daemons, or one fresh local daemon per host name
  local exe = hosts_mod.self_exe()
  local key, keydir = os.getenv("DCA_KEY_FILE"), nil
  local daemons, hosts
  if o.hosts then
    hosts, err = hosts_mod.read_file(o.hosts)
    if not hosts then io.stderr:write(err, "\n") return 2 end
  end
  if not core.loop or not core.connect then
    io.stderr:write("dca run: this dca has no control plane (dca.core.loop/connect)\n")
    return 3
  end
  if not o.hosts then
    if not key then key, keydir = hosts_mod.fresh_key() end
    local names = spec_mod.hosts(spec)
    daemons, err = hosts_mod.start_local(names, { exe = exe, key = key, clock = o.sim and "sim" or nil,
                                                   log_dir = keydir or os.getenv("TMPDIR") or "/tmp",
                                                   state_dir = o.state_dir })
    if not daemons then io.stderr:write("dca run: ", err, "\n") return 3 end
    hosts = daemons.hosts
    for _, name in ipairs(names) do say(string.format("host %s: daemon at %s (pid %d)", name, hosts[name], daemons.pids[name])) end
  end
  for _, h in ipairs(spec_mod.hosts(spec)) do
    if not hosts[h] then io.stderr:write("dca run: no daemon for host '", h, "' in ", tostring(o.hosts), "\n") return 2 end
  end
  local function give_up(c)
    if daemons then daemons:stop() end
    if keydir then os.execute("rm -rf " .. hosts_mod.sh_quote(keydir)) end
    return c
  end

  -- the configuration repository: the system's defaults and --set, on the root's host, replicated to all
  do
    local config = require "dca.config"
    local used = {}
    for _, h in ipairs(spec_mod.hosts(spec)) do used[h] = hosts[h] end
    local file = o.config or (not o.no_config and config.defaults_file(o.file)) or nil
    local origin = (spec.host and used[spec.host]) and spec.host or spec_mod.hosts(spec)[1]
    local line, cerr = config.seed_run(used, origin, { key_file = key, file = file, set = o.set })
    if cerr then io.stderr:write("dca run: ", cerr, "\n") return give_up(file and cerr:find(file, 1, true) == 1 and 2 or 3) end
    if line then say(line) end
    -- every config("key") parameter read once here: a missing key or a wrong type stops the run before
    -- anything is started (all of them listed)
    local okc, kerr = config.check_spec(used, origin, spec, { key_file = key })
    if not okc then io.stderr:write("dca run: ", kerr, "\n") return give_up(2) end
  end

  local loop = core.loop()
  local code
  local sup
  -- the end of a run: the world's summary (with --sim), then the tree, then the world stopped
  local function wind_up()
    local function down()
      sup:shutdown(function()
        if world then world:stop(function() loop:stop() end) else loop:stop() end
      end)
    end
    if not world then down() return end
    world:summary(core.now() - t0, function(lines)
      for _, l in ipairs(lines) do emit(l) end
      down()
    end)
  end
  local rt = srt.new({ hosts = hosts, key = key, exe = exe, daemon_host = spec.host,
    report = function(msg)
      if msg.type == "log" then say(msg.line, msg.at)
      elseif msg.type == "done" then
        say(string.format("%s: DONE %s", spec.path, supervisor.show(msg.value)))
        if not o.repl then code = 0 wind_up() end
      elseif msg.type == "aborted" then
        local text = string.format("%s: ABORTED at %s: %s", spec.path, tostring(msg.path), tostring(msg.reason))
        local function out(t)
          if not (o.repl and srt.to_followers(followers, t) > 0) then io.stderr:write(t, "\n") end
        end
        -- in order with the stamped lines (with --sim)
        if world and world.ch then world:stamp(text, function(t) out(string.format("[sim %8.3f] %s", t, text)) end)
        else out(text) end
        if not o.repl then code = 1 wind_up() end
      end
    end,
    log = say })
  sup = supervisor.new(spec, rt, { progress = true })
  sup.hosts = hosts
  rt.bind(sup)
  local function stop_all(c)
    if code == nil then code = c end
    sup:shutdown(function()
      if world then world:stop(function() loop:stop() end) else loop:stop() end
    end)
    core.after(15, function() loop:stop() end) -- a bounded stop: daemons are killed below in any case
  end
  core.on_signal(function(sig) say("interrupted (SIG" .. tostring(sig) .. "): stopping") stop_all(130) end)

  -- the start must finish within --timeout (from the moment the tree starts coming up)
  local deadline
  local function arm_deadline()
    deadline = core.after(o.timeout, function()
      if sup.state == "starting" or sup.state == "new" then
        io.stderr:write(string.format("dca run: the start did not finish within %gs\n", o.timeout))
        stop_all(3)
      end
    end)
  end
  -- the root listens for consoles (`dca repl main`) and registers its path with its host's daemon
  local listener = core.listen("127.0.0.1:0", srt.key_opts(key), function(ch)
    ch:on_message(function(msg, id) srt.console(ch, id, msg, sup, followers) end)
    ch:on_close(function() followers[ch] = nil end)
  end)
  local root_daemon = hosts[spec.host]
  if listener and root_daemon then
    core.connect(root_daemon, srt.key_opts(key), function(dch)
      if not dch then return end
      rt.root_daemon = dch
      dch:request({ type = "register", name = spec.path, endpoints = { control = listener:address() } }, 5, function() end)
      say(string.format("console: dca repl %s --daemon %s --key %s", spec.path, root_daemon, tostring(key)))
    end)
  end

  -- reload: the file again (validated first; on an error the old version keeps running), or the modules
  local function reload(what, cb)
    if what == "modules" then
      local lines = {}
      for _, name in ipairs({ "dca.supervisor", "dca.supervisor.console" }) do
        local path = package.searchpath(name, package.path)
        local fn, lerr = loadfile(path)
        if not fn then lines[#lines + 1] = lerr
        else
          local okm, merr = pcall(fn, name)
          if okm then package.loaded[name] = merr lines[#lines + 1] = name .. ": reloaded (state kept)"
          else lines[#lines + 1] = name .. ": " .. tostring(merr) end
        end
      end
      cb(lines)
      return
    end
    local new, lerr = M.load(what or o.file, o.root)
    if not new then cb({ "reload refused, the running version is kept:", lerr }) return end
    sup:update(new, function(lines)
      if #lines == 0 then lines = { "no change" } end
      cb(lines)
    end)
  end
  sup.reload_hook = reload
  if o.watch then
    local w, werr = core.watch_file(o.file)
    if not w then io.stderr:write("dca run: --watch: ", werr, "\n")
    else
      core.every(0.2, function()
        if w:changed() then
          reload(nil, function(lines) for _, l in ipairs(lines) do say("reload: " .. l) end end)
        end
      end)
    end
  end

  local function bring_up()
    arm_deadline()
    sup:configure(function(cok, cerr)
      if not cok then
        io.stderr:write("dca run: start failed: ", tostring(cerr), "\n")
        stop_all(3)
        return
      end
      deadline:cancel()
      say(spec.path .. ": the whole tree is configured: run")
      -- simulated time starts once every process the start ran has its run (a repeatable start)
      sup:run_expr(nil, function()
        if not world then return end
        world:go(function(r, gerr)
          if not r then io.stderr:write("dca run: the world did not start its time: ", tostring(gerr), "\n") stop_all(3) end
        end)
      end)
      if o.repl and listener then
        -- the console is `dca repl` on the root's console endpoint, in its own process on this terminal, so
        -- that line editing owns the terminal while this process's loop keeps the system running
        local cmd = string.format("%s repl %s%s </dev/tty >/dev/tty 2>&1 & echo $!", hosts_mod.sh_quote(exe),
          hosts_mod.sh_quote(listener:address()), key and (" --key " .. hosts_mod.sh_quote(key)) or "")
        local p = io.popen(cmd, "r")
        local pid = p and tonumber((p:read("a") or ""):match("%d+"))
        if p then p:close() end
        if not pid then io.stderr:write("dca run: could not start the console\n")
        else
          local watch
          watch = core.every(0.1, function()
            if not hosts_mod.alive(pid) then
              watch:cancel()
              local st = sup.outcome and sup.outcome.status
              stop_all(st == "done" and 0 or (st == "aborted" and 1 or 130))
            end
          end)
        end
      end
    end)
  end
  if o.sim then
    -- the world first (the nodes on the simulated clock find it when they start), through the first host
    local first = spec_mod.hosts(spec)[1]
    world = sim.new({ daemon = hosts[first], host = first, key = key, world = o.sim, seed = o.seed,
                      door_width = o.door_width, record = o.record, jammed = o.jammed,
                      wait = o.timeout, realtime = o.realtime, periods = sim.period_leaves(spec) })
    say(string.format("world: starting `dca sim --serve --world %s` on host %s", o.sim, first))
    world.on_lost = function(reason)
      io.stderr:write("dca run: ", reason, " (the nodes on its clock stop with it)\n")
      if code == nil then code = 1 end
    end
    local function start_world()
      world:start(function(wok, werr)
        if not wok then
          io.stderr:write("dca run: ", tostring(werr), "\n")
          code = 3
          world:stop(function() loop:stop() end)
          return
        end
        say("world: ready; time stands at 0 until the root runs")
        bring_up()
      end)
    end
    if not o.hosts then
      start_world()
    else
      -- daemons of a hosts file must be on the simulated clock (their ping says so)
      local names, left, bad = spec_mod.hosts(spec), 0, {}
      left = #names
      for _, h in ipairs(names) do
        core.connect(hosts[h], srt.key_opts(key), function(ch, cerr)
          local function one(reason)
            if reason then bad[#bad + 1] = reason end
            left = left - 1
            if left > 0 then return end
            if #bad > 0 then
              io.stderr:write("dca run: --sim needs every daemon on the simulated clock: ", table.concat(bad, "; "), "\n")
              code = 2
              loop:stop()
            else
              start_world()
            end
          end
          if not ch then one(string.format("host %s at %s: %s", h, hosts[h], tostring(cerr))) return end
          ch:on_message(function() end)
          ch:request({ type = "ping" }, 10, function(r, perr)
            ch:close()
            if not r then one(string.format("host %s: %s", h, tostring(perr)))
            elseif r.clock ~= "sim" then
              one(string.format("the daemon of host %s runs on the %s clock (start it with --clock sim)", h,
                tostring(r.clock or "wall")))
            else one(nil) end
          end)
        end)
      end
    end
  else
    bring_up()
  end
  loop:run()
  rt.close()
  if world then world:close() end
  if daemons then daemons:stop() end
  if keydir then os.execute("rm -rf " .. hosts_mod.sh_quote(keydir)) end
  return code or 1
end

return M
