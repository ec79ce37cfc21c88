-- dca.deploy: what `dca deploy` writes for a system's hosts (docs/deploy.md): per host, the systemd unit of its
-- daemon with that host's options; an Ansible inventory of the hosts; the hosts file; the Ansible play. Pure: text
-- in, text out (the CLI, lua/dca/cli/deploy.lua, reads and writes the files).
--
--   local deploy = require "dca.deploy"
--   local text = deploy.unit()                         -- the package's unit: options from /etc/default/dca-daemon
--   local text = deploy.unit({ "--host", "arm", ... }) -- a host's unit: those options
--   local files, err = deploy.files(names, hosts, { system = "door.dca", hosts_file = "lab.hosts" })
--   -- files = { ["units/arm/dca-daemon.service"] = text, ["inventory.ini"] = text, ["hosts"] = text,
--   --           ["deploy.yml"] = text }; err names a host without an address, or one that is not TCP
local M = {}

local concat, sort, sformat, ipairs = table.concat, table.sort, string.format, ipairs

--- Where the package puts what the unit names.
M.exe, M.key_file, M.hosts_file = "/usr/bin/dca", "/etc/dca/key", "/etc/dca/hosts"

-- The unit's lines before and after ExecStart. Hardening that still lets the daemon spawn nodes (fork, exec,
-- SCHED_FIFO, mlockall), open robots' devices and reach the network (docs/deploy.md, "The unit").
local head = [[
[Unit]
Description=dca daemon (Executer, NameServer, configuration replica)%s
Documentation=file:///usr/share/doc/dca/README.md
Wants=network-online.target
After=network-online.target

[Service]
# READY=1 once it listens, WATCHDOG=1 from its event loop, STOPPING=1 when it stops (sd_notify)
Type=notify
NotifyAccess=main
WatchdogSec=30s
User=dca
Group=dca
# robots' serial and USB devices
SupplementaryGroups=dialout
]]

local tail = [[
StateDirectory=dca
StateDirectoryMode=0700
RuntimeDirectory=dca
RuntimeDirectoryMode=0700
# the nodes' Unix sockets
Environment=XDG_RUNTIME_DIR=%t/dca
Environment=HOME=%S/dca
# the nodes and supervisors it starts authenticate with its key
Environment=DCA_KEY_FILE=/etc/dca/key
Restart=on-failure
RestartSec=2s
# the daemon stops its children itself (SIGTERM, then SIGKILL after --grace); what is left then is killed
KillMode=mixed
TimeoutStopSec=20s
# a descriptor per connection and per child; real-time nodes (dca node --rt-priority) lock their memory
LimitNOFILE=65536
LimitRTPRIO=95
LimitMEMLOCK=infinity
UMask=0077
NoNewPrivileges=yes
CapabilityBoundingSet=
ProtectSystem=strict
ProtectHome=read-only
PrivateTmp=yes
ProtectKernelTunables=yes
ProtectKernelModules=yes
ProtectKernelLogs=yes
ProtectControlGroups=yes
ProtectClock=yes
ProtectHostname=yes
RestrictSUIDSGID=yes
RestrictNamespaces=yes
LockPersonality=yes
SystemCallArchitectures=native
SystemCallFilter=@system-service
RestrictAddressFamilies=AF_UNIX AF_INET AF_INET6 AF_NETLINK AF_CAN

[Install]
WantedBy=multi-user.target
]]

--- One argument of ExecStart as systemd reads it (systemd.service(5), "Command lines"): quoted when it holds
--- anything but plain characters; '%' (specifiers) and '$' (variables) doubled.
function M.exec_arg(s)
  s = s:gsub("%%", "%%%%"):gsub("%$", "$$")
  if s ~= "" and not s:find("[%s\"'\\;]") then return s end
  return '"' .. s:gsub("\\", "\\\\"):gsub('"', '\\"') .. '"'
end

--- The unit of a host's daemon. `args`: its options (--host, --listen, --peer ...); nil: the package's unit,
--- whose options come from $DCA_DAEMON_ARGS in /etc/default/dca-daemon. `what`: a line saying where it came from.
function M.unit(args, what)
  local lines = { sformat(head, args and args.host_name and (" of host " .. args.host_name) or "") }
  if what then table.insert(lines, 1, "# " .. what .. "\n") end
  local exec = { M.exe, "daemon", "--key", M.key_file, "--state-dir", "%S/dca" }
  if args then
    for _, a in ipairs(args) do exec[#exec + 1] = M.exec_arg(a) end
  else
    lines[#lines + 1] = "# DCA_DAEMON_ARGS: --host NAME, --listen ADDR, --peer ADDR... (dca daemon --help)\n"
    lines[#lines + 1] = "Environment=DCA_DAEMON_ARGS=\nEnvironmentFile=-/etc/default/dca-daemon\n"
    exec[#exec + 1] = "$DCA_DAEMON_ARGS"
  end
  lines[#lines + 1] = "ExecStart=" .. concat(exec, " ") .. "\n"
  lines[#lines + 1] = tail
  return concat(lines)
end

--- The host part of a TCP address as a daemon takes it (host/net/framed_socket.h: a numeric IP, or localhost;
--- "tcp:" before it allowed): "10.0.0.2:7000" -> "10.0.0.2", "[fd00::2]:7000" -> "fd00::2"; nil for anything else
--- (a Unix socket cannot reach another machine; a name is not resolved).
function M.tcp_host(addr)
  addr = addr:gsub("^tcp:", "")
  local v6 = addr:match("^%[([%x:.]+)%]:%d+$")
  if v6 then return v6 end
  local v4 = addr:match("^(%d+%.%d+%.%d+%.%d+):%d+$")
  if v4 then return v4 end
  return addr:match("^(localhost):%d+$")
end

-- The hosts `names` with their addresses in `hosts`, sorted by name: { {name=, addr=, ip=} } | nil, err
local function fleet(names, hosts, hosts_file)
  local list = {}
  for _, name in ipairs(names) do
    local addr = hosts[name]
    if not addr then return nil, sformat("no address for host '%s' in %s", name, hosts_file) end
    local ip = M.tcp_host(addr)
    if not ip then
      return nil, sformat("host '%s' in %s: '%s' is not a TCP address (IP:PORT, [IPv6]:PORT): a fleet's daemons " ..
        "listen on TCP", name, hosts_file, addr)
    end
    list[#list + 1] = { name = name, addr = addr, ip = ip }
  end
  sort(list, function(a, b) return a.name < b.name end)
  return list
end

--- The daemon's options on host `h` of `list`: its name, its address, every other host as a peer.
function M.daemon_args(list, h)
  local args = { "--host", h.name, "--listen", h.addr, host_name = h.name }
  for _, other in ipairs(list) do
    if other ~= h then args[#args + 1] = "--peer" args[#args + 1] = other.addr end
  end
  return args
end

--- The Ansible play (docs/deploy.md): on every host of the inventory, the package, the cluster key, the hosts
--- file and the host's unit, then the daemon enabled and started (restarted when one of them changed); one host
--- first (the canary: a daemon that does not become ready there stops the play), then the others.
M.play = [[
- hosts: dca
  become: true
  serial: [1, "100%"]
  vars: { dca_deb: dca.deb, dca_key: "{{ lookup('env', 'HOME') }}/.config/dca/key" }
  tasks:
    - ansible.builtin.copy: { src: "{{ dca_deb }}", dest: /var/cache/dca.deb }
    - ansible.builtin.apt: { deb: /var/cache/dca.deb }
    - ansible.builtin.copy: { src: "{{ dca_key }}", dest: /etc/dca/key, owner: dca, group: dca, mode: "0600" }
      notify: restart
    - ansible.builtin.copy: { src: hosts, dest: /etc/dca/hosts, mode: "0644" }
    - ansible.builtin.copy: { src: "units/{{ inventory_hostname }}/dca-daemon.service", dest: /etc/systemd/system/ }
      notify: restart
    - ansible.builtin.systemd: { name: dca-daemon, enabled: true, state: started, daemon_reload: true }
  handlers:
    - { name: restart, ansible.builtin.systemd: { name: dca-daemon, state: restarted, daemon_reload: true } }
]]

--- Every file `dca deploy` writes, by relative path. names: the system's hosts (dca.supervisor.spec.hosts);
--- hosts: name -> address (dca.launch.hosts.read_file); o.system, o.hosts_file: the paths given, for comments.
function M.files(names, hosts, o)
  local list, err = fleet(names, hosts, o.hosts_file)
  if not list then return nil, err end
  local what = sformat("written by `dca deploy %s --hosts %s`", o.system, o.hosts_file)
  local run = " (docs/deploy.md): ansible-playbook -i inventory.ini deploy.yml\n"
  local files = { ["deploy.yml"] = "# " .. what .. run .. M.play }
  local inv, hf = { "# " .. what .. ": the system's hosts for Ansible", "[dca]" }, { "# " .. what }
  for _, h in ipairs(list) do
    files["units/" .. h.name .. "/dca-daemon.service"] = M.unit(M.daemon_args(list, h), what)
    inv[#inv + 1] = sformat("%s ansible_host=%s dca_address=%s", h.name, h.ip, h.addr)
    hf[#hf + 1] = sformat("%s %s", h.name, h.addr)
  end
  files["inventory.ini"] = concat(inv, "\n") .. "\n"
  files["hosts"] = concat(hf, "\n") .. "\n"
  return files, list
end

return M
