-- Time to roll all hosts (BENCHMARKS.md format): a rolling upgrade of a controller package (docs/deploy.md,
-- "Rolling upgrade of a package") over H robots, each a group on a host of its own (daemons on loopback, one per
-- host; tests/lua/launch/upgrade_robots.dca's Robot: Counter -> PkgScale of the test package pkg_ok ->
-- Threshold), with real nodes and supervisors, wall clock:
--
--   RESULT bench=package_upgrade variant=H_hosts_watch0 n=.. p50_us=.. p99_us=.. ... per_host_p50_us=..
--     from the upgrade's start to its answer "done": the plan (every daemon's package_status), then per host
--     the file's install by its daemon (its bytes over the control channel, written and renamed) and the live
--     restart of its leaf; the canary's watch is 0 (what it adds is its length, on the wall clock). Samples
--     alternate between two builds (pkg_ok as built, and its k = 3 rebuild), so that each one installs.
--   RESULT bench=leaf_live_restart variant=same_host n=.. ...
--     the baseline, alternated with it sample by sample (A B A B): one plain live restart of one such leaf
--     (restart('main.r1.sc'): stop, a fresh node, its ports checked, wired both ways, run), to its answer.
-- Usage: dca lua tests/bench/upgrade_bench.lua [N] [H...]   (N samples of each, default 10; H default 3 and 6)
local core = require "dca.core"
local S = require "dca.scenario"
local T = require "dca.testing"
local upgrade = require "dca.supervisor.upgrade"
S.backend = "real"
local sformat = string.format

local N = tonumber(arg and arg[1]) or 10
local SIZES = {}
for i = 2, (arg and #arg or 0) do SIZES[#SIZES + 1] = tonumber(arg[i]) end
if #SIZES == 0 then SIZES = { 3, 6 } end

local packages = os.getenv("DCA_TEST_PACKAGES_DIR")
  or (T.exe:match("^(.*)/bin/[^/]+$") or ".") .. "/tests/packages/lib"
local BUILDS = { packages .. "/variants/k3/pkg_ok.dca.so", packages .. "/pkg_ok.dca.so" }
for _, f in ipairs(BUILDS) do
  if not io.open(f) then error(f .. " is missing: build the target dca_test_packages first", 0) end
end

local function stats(samples)
  table.sort(samples)
  local n = #samples
  local function q(p) return samples[math.max(1, math.min(n, math.ceil(p * n)))] * 1e6 end
  return sformat("n=%d p50_us=%.0f p99_us=%.0f p999_us=%.0f max_us=%.0f", n, q(0.5), q(0.99), q(0.999), q(1)), q(0.5)
end

-- The robots' system with `h` hosts: upgrade_robots.dca's Robot, and a main of h of them.
local function system(h)
  local text = T.read(T.src .. "/tests/lua/launch/upgrade_robots.dca")
  local robot = text:match("(process Robot.-\n}\n)")
  local lines, names = {}, {}
  for i = 1, h do
    lines[#lines + 1] = sformat("    r%d instof Robot(\"h%d\");", i, i)
    names[#names + 1] = "r" .. i
  end
  return "use pkg_ok;\n" .. robot .. "process main() {\n  instantiated_processes {\n" .. table.concat(lines, "\n")
    .. "\n  }\n  internal_event_actions { " .. table.concat(names, ", ") .. " }\n}\n"
end

for _, h in ipairs(SIZES) do
  local dir = T.tmpdir()
  os.execute("mkdir '" .. dir .. "/packages' && cp '" .. BUILDS[2] .. "' '" .. dir .. "/packages/'")
  T.write(dir .. "/robots.dca", system(h))
  local sys = S.system(dir .. "/robots.dca")
  sys:up(60)
  sys:run()
  sys:wait_state("main.r" .. h .. ".sc", "running", 30)
  local rolls, restarts = {}, {}
  for i = 1, N do
    local t0, res = core.now(), nil
    sys.sup:restart("main.r1.sc", function(ok, err) res = { ok, err } end)
    sys:wait("the restart", function() return res ~= nil end, 30)
    assert(res[1], res[2])
    restarts[#restarts + 1] = core.now() - t0
    t0, res = core.now(), nil
    upgrade.run(sys.sup, { file = BUILDS[1 + i % 2], canary = "h1", watch = 0 },
      function(ok, text) res = { ok, text } end)
    sys:wait("the upgrade", function() return res ~= nil end, 60)
    assert(res[1], res[2])
    rolls[#rolls + 1] = core.now() - t0
  end
  local roll, roll_p50 = stats(rolls)
  io.stdout:write(sformat("RESULT bench=package_upgrade variant=%d_hosts_watch0 %s per_host_p50_us=%.0f\n", h, roll,
    roll_p50 / h))
  io.stdout:write(sformat("RESULT bench=leaf_live_restart variant=same_host %s hosts=%d\n", (stats(restarts)), h))
  io.stdout:flush()
  sys:stop()
end
T.cleanup()
