-- `dca deploy FILE.dca --hosts HOSTS`: the files that install a system's hosts as daemons under systemd, one
-- per machine, with Ansible (docs/deploy.md): argv, reading and writing; the texts are dca.deploy's.
local args = require "dca.cli.args"

local M = {}

M.summary = "write the systemd units, Ansible inventory and play that install a system's hosts (docs/deploy.md)"
M.usage = [[usage: dca deploy FILE.dca --hosts HOSTS [-o DIR] [--root NAME]

Writes into DIR (default: deploy) what installs the daemons of the system's hosts, one per machine, under
systemd (docs/deploy.md):
  units/HOST/dca-daemon.service   each host's unit: `dca daemon --host HOST --listen ADDRESS --peer ...`, its
                                  address from HOSTS and every other host as a peer, Type=notify, hardened
  inventory.ini                   the hosts for Ansible: group dca, ansible_host, dca_address
  hosts                           the system's hosts file (/etc/dca/hosts on every machine)
  deploy.yml                      the Ansible play: on every host the package, the cluster key, the hosts file
                                  and the host's unit, then the daemon enabled and started
HOSTS is a hosts file ("name address" per line, IP:PORT or [IPv6]:PORT) that names every host of the system (its
standby hosts too). The file is checked as by `dca check` first. Then:
  ansible-playbook -i DIR/inventory.ini DIR/deploy.yml -e dca_deb=$PWD/dca_VERSION_ARCH.deb]]

-- Makes directory `path` and its parents (0700; those that exist are kept). --> true | nil, err
local function make_dirs(path)
  local core = require "dca.core"
  local at = path:sub(1, 1) == "/" and "" or "."
  for part in path:gmatch("[^/]+") do
    at = at .. "/" .. part
    local ok, err = core.make_dir(at)
    if not ok and not tostring(err):find("exists", 1, true) then return nil, err end
  end
  return true
end

local function write(path, text)
  local dir = path:match("^(.*)/[^/]+$")
  if dir then
    local ok, err = make_dirs(dir)
    if not ok then return nil, err end
  end
  local f, err = io.open(path, "w")
  if not f then return nil, err end
  f:write(text)
  f:close()
  return true
end

function M.main(argv)
  local o, err = args.parse(argv, "dca deploy", { ["--hosts"] = "value", ["-o"] = "value:out", ["--root"] = "value" })
  if not o then return args.usage_error(err, M.usage) end
  if not o[1] or not o.hosts then
    return args.usage_error("dca deploy: FILE.dca and --hosts HOSTS are needed", M.usage)
  end
  local spec, serr = require("dca.load").spec(o[1], { root = o.root })
  if not spec then io.stderr:write(serr, "\n") return 1 end
  local hosts, herr = require("dca.launch.hosts").read_file(o.hosts)
  if not hosts then io.stderr:write("dca deploy: ", herr, "\n") return 1 end
  local names = require("dca.supervisor.spec").hosts(spec)
  local files, list = require("dca.deploy").files(names, hosts, { system = o[1], hosts_file = o.hosts })
  if not files then io.stderr:write("dca deploy: ", list, "\n") return 1 end
  local dir, paths = o.out or "deploy", {}
  for path in pairs(files) do paths[#paths + 1] = path end
  table.sort(paths)
  for _, path in ipairs(paths) do
    local ok, werr = write(dir .. "/" .. path, files[path])
    if not ok then io.stderr:write("dca deploy: cannot write ", dir, "/", path, ": ", tostring(werr), "\n") return 1 end
  end
  local written = {}
  for i, h in ipairs(list) do written[i] = h.name end
  io.stdout:write(string.format("dca deploy: %d hosts (%s) in %s/\n", #list, table.concat(written, ", "), dir))
  for _, path in ipairs(paths) do io.stdout:write("  ", dir, "/", path, "\n") end
  return 0
end

return M
