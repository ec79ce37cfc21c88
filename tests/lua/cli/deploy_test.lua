-- `dca deploy` as a user runs it (docs/deploy.md): the files for scripts/systems/test_three_hosts.dca on the
-- hosts of tests/lua/cli/deploy/lab.hosts against their golden copies (tests/lua/cli/deploy/*.golden;
-- DCA_GOLDEN_UPDATE=1 rewrites them), every unit accepted by `systemd-analyze verify`, the play by
-- `ansible-playbook --syntax-check` and equal to docs/deploy.md's; hosts missing from the file, and usage errors.
local T = require "dca.testing"
local suite = T.suite("deploy")

local golden = T.src .. "/tests/lua/cli/deploy/"

-- Runs `dca deploy ARGS` in the source tree (so the paths it writes into its comments are the relative ones).
local function deploy(args, rc, ...)
  local out, code = T.sh("cd '" .. T.src .. "' && " .. T.exe .. " deploy " .. args)
  T.eq(code, rc, "dca deploy " .. args .. ":\n" .. out)
  for _, fragment in ipairs({ ... }) do T.contains(out, fragment, "dca deploy " .. args) end
  return out
end

local function three_hosts()
  local dir = T.tmpdir()
  deploy("scripts/systems/test_three_hosts.dca --hosts tests/lua/cli/deploy/lab.hosts -o " .. dir, 0,
    "dca deploy: 3 hosts (manip, platform, vision) in " .. dir .. "/\n")
  return dir
end

suite:case("three_hosts_units_inventory_hosts_and_play_are_the_golden_ones", function()
  local dir = three_hosts()
  T.golden(golden .. "inventory.ini.golden", T.read(dir .. "/inventory.ini"), "inventory.ini")
  T.golden(golden .. "hosts.golden", T.read(dir .. "/hosts"), "hosts")
  T.golden(golden .. "deploy.yml.golden", T.read(dir .. "/deploy.yml"), "deploy.yml")
  T.golden(golden .. "manip.service.golden", T.read(dir .. "/units/manip/dca-daemon.service"), "manip's unit")
  -- the other units differ from manip's in its name and options only
  local manip = T.read(dir .. "/units/manip/dca-daemon.service")
  for name, exec in pairs({
    vision = "--host vision --listen 10.0.0.2:7000 --peer [fd00::4]:7000 --peer 10.0.0.3:7000",
    platform = "--host platform --listen 10.0.0.3:7000 --peer [fd00::4]:7000 --peer 10.0.0.2:7000" }) do
    local unit = T.read(dir .. "/units/" .. name .. "/dca-daemon.service")
    local expected = manip:gsub("of host manip\n", "of host " .. name .. "\n")
      :gsub("%-%-host manip [^\n]*", (exec:gsub("%%", "%%%%")))
    T.eq(unit, expected, name .. "'s unit")
  end
end)

suite:case("the_units_pass_systemd_analyze_verify", function()
  local _, has = T.sh("command -v systemd-analyze")
  T.eq(has, 0, "systemd-analyze (scripts/setup installs systemd)")
  local dir = three_hosts()
  for _, name in ipairs({ "manip", "platform", "vision" }) do
    -- it wants ExecStart's program where the unit says: this dca
    local unit = T.read(dir .. "/units/" .. name .. "/dca-daemon.service"):gsub("ExecStart=/usr/bin/dca ", "ExecStart=" .. T.exe .. " ")
    local path = T.write(dir .. "/" .. name .. ".service", unit)
    local out, rc = T.sh("systemd-analyze verify " .. path)
    T.eq(rc, 0, out)
    T.eq(out, "", "systemd-analyze verify " .. name .. "'s unit")
  end
end)

suite:case("the_play_passes_ansible_syntax_check_and_is_the_one_in_the_docs", function()
  local dir = three_hosts()
  local out, rc = T.sh("cd " .. dir .. " && ansible-playbook --syntax-check -i inventory.ini deploy.yml")
  T.eq(rc, 0, "ansible-playbook --syntax-check (scripts/setup installs ansible-core):\n" .. out)
  local docs = T.read(T.src .. "/docs/deploy.md")
  local play = docs:match("\n```yaml\n(.-)```\n")
  T.ok(play, "docs/deploy.md shows the play in a ```yaml block")
  T.eq(play, require("dca.deploy").play, "the play in docs/deploy.md")
end)

suite:case("every_host_and_standby_host_needs_a_tcp_address", function()
  local hosts = T.tmpfile("manip 10.0.0.4:7000\nbase 10.0.0.5:7000\nvision 10.0.0.2:7000\nvision2 10.0.0.3:7000\n",
    ".hosts")
  deploy("scripts/systems/test_failover.dca --hosts " .. hosts .. " -o " .. T.tmpdir(), 1,
    "dca deploy: no address for host 'vision3' in " .. hosts)
  local unix = T.tmpfile("vision unix:/run/v.sock\nplatform 10.0.0.3:7000\nmanip 10.0.0.4:7000\n", ".hosts")
  deploy("scripts/systems/test_three_hosts.dca --hosts " .. unix .. " -o " .. T.tmpdir(), 1,
    "host 'vision' in " .. unix .. ": 'unix:/run/v.sock' is not a TCP address")
end)

suite:case("errors_in_the_system_and_usage_errors", function()
  local bad = T.tmpfile("process main() {\n  instantiated_processes { x instof NoSuchType(\"h\"); }\n}\n")
  deploy(bad .. " --hosts tests/lua/cli/deploy/lab.hosts -o " .. T.tmpdir(), 1, bad .. ":2:")
  deploy("scripts/systems/test_three_hosts.dca --hosts /nonexistent/hosts", 1, "dca deploy: cannot read hosts file")
  deploy("", 2, "usage: dca deploy FILE.dca --hosts HOSTS")
  deploy("scripts/systems/test_three_hosts.dca", 2, "FILE.dca and --hosts HOSTS are needed")
  deploy("x.dca --hosts", 2, "dca deploy: --hosts needs a value")
end)

return suite:run(...)
