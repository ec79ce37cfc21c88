-- dca.launch.hosts: the hosts of a run: a hosts file, or one local daemon per host name on loopback.
--
--   local hosts = require "dca.launch.hosts"
--   local map, err = hosts.read_file(path)            -- "name address" per line, # comments
--   local key = hosts.fresh_key()                      -- a new 0600 key file in a fresh 0700 temp dir
--   local set = hosts.start_local(names, { exe =, key =, clock = "wall"|"sim", log_dir =, state_dir = })
--   -- state_dir: each daemon's configuration replica in STATE_DIR/<name> (default: a fresh directory, removed
--   -- by set:stop())
--   -- set.hosts = { name = "127.0.0.1:PORT" }, set.pids = { name = pid }; set:stop() (LIFO, waits for /proc)
local M = {}

local ipairs, pairs, type, tostring, sformat, tonumber = ipairs, pairs, type, tostring, string.format, tonumber

local core = require "dca.core"

-- Every process here starts from an argv (core.spawn: posix_spawn, never a shell), so a host name or an
-- argument holding quotes, newlines or NULs reaches the program intact or not at all.

--- This process's pid and executable (the `dca` to start daemons, nodes and supervisors with).
function M.self_pid()
  local f = io.open("/proc/self/stat", "r")
  if not f then return nil end
  local pid = f:read("l"):match("^(%d+)")
  f:close()
  return tonumber(pid)
end

function M.self_exe()
  local env = os.getenv("DCA_EXE")
  if env and env ~= "" then return env end
  local ok, core = pcall(require, "dca.core")
  if ok and core.exe_path then
    local p = core.exe_path()
    if p then return p end
  end
  return "dca"
end

--- Reads a hosts file: one `name address` per line ("vision 10.0.0.2:7000"); `#` starts a comment.
function M.read_file(path)
  local f, err = io.open(path, "r")
  if not f then return nil, "cannot read hosts file: " .. tostring(err) end
  local map, n = {}, 0
  for line in f:lines() do
    n = n + 1
    local text = line:gsub("#.*$", "")
    local name, addr = text:match("^%s*(%S+)%s+(%S+)%s*$")
    if name then map[name] = addr
    elseif text:match("%S") then
      f:close()
      return nil, sformat("%s:%d:1: expected 'name address', got '%s'", path, n, line)
    end
  end
  f:close()
  return map
end

--- A fresh temp directory (0700) holding a new key file (0600, 32 random bytes as hex). --> key path, dir
function M.fresh_key()
  local dir = os.tmpname()
  os.remove(dir)
  local f = assert(io.open("/dev/urandom", "rb"))
  local bytes = f:read(32)
  f:close()
  local ok, err = core.make_dir(dir)
  if ok then ok, err = core.write_new_file(dir .. "/key", (bytes:gsub(".", function(c) return sformat("%02x", c:byte()) end))) end
  if not ok then error("cannot create a key file in " .. dir .. ": " .. tostring(err)) end
  return dir .. "/key", dir
end

--- Free loopback TCP ports, one per name (the kernel picks them: bind port 0 and close again).
function M.free_ports(n)
  local ports = core.free_tcp_ports(n)
  if #ports == n then return ports end
  -- no sockets to spare: spread over a high range by pid (the daemon's bind error names a clash)
  local base = 20000 + ((M.self_pid() or 0) * 7) % 30000
  for i = 1, n do ports[i] = base + i end
  return ports
end

local Set = {}
Set.__index = Set

--- Starts one `dca daemon` per host name on 127.0.0.1 (peers of each other). Returns the set; each daemon's
--- output goes to <log_dir>/<name>.log.
function M.start_local(names, opts)
  local ports = M.free_ports(#names)
  local set = setmetatable({ hosts = {}, pids = {}, order = {}, logs = {}, opts = opts }, Set)
  -- the configuration replicas: DIR/<host> under opts.state_dir (kept), else a fresh directory of this set
  -- (removed by stop): a run never shares, nor finds, the repository of another run unless asked to
  local state = opts.state_dir
  if not state then
    state = os.tmpname()
    os.remove(state)
    set.own_state = state
  end
  set.state_dir = state
  for i, name in ipairs(names) do set.hosts[name] = "127.0.0.1:" .. ports[i] end
  for _, name in ipairs(names) do
    local argv = { opts.exe, "daemon", "--host", name, "--listen", set.hosts[name], "--key", opts.key }
    for _, other in ipairs(names) do
      if other ~= name then argv[#argv + 1] = "--peer" argv[#argv + 1] = set.hosts[other] end
    end
    if opts.clock then argv[#argv + 1] = "--clock" argv[#argv + 1] = opts.clock end
    argv[#argv + 1] = "--state-dir"
    argv[#argv + 1] = state .. "/" .. name
    for _, dir in ipairs(opts.remove_on_exit or {}) do argv[#argv + 1] = "--remove-on-exit" argv[#argv + 1] = dir end
    if set.own_state then argv[#argv + 1] = "--remove-on-exit" argv[#argv + 1] = set.own_state end
    local log = (opts.log_dir or "/tmp") .. "/" .. name .. ".log"
    set.logs[name] = log
    -- its own session: a Ctrl-C at the terminal reaches `dca run` only, which stops the tree LIFO first; and it
    -- stops when `dca run` dies, whatever kills it (host/spawn.h)
    local pid, serr = core.spawn(argv, { stdout = log, session = true })
    if not pid then set:stop() return nil, sformat("could not start the daemon of host %s: %s", name, serr) end
    set.pids[name] = pid
    set.order[#set.order + 1] = name
  end
  -- each daemon prints "dca daemon: host NAME listening on ADDR" when it accepts connections: wait for it
  local deadline = os.time() + (opts.ready_timeout or 10)
  for _, name in ipairs(names) do
    while true do
      local f = io.open(set.logs[name], "r")
      local text = f and f:read("a") or ""
      if f then f:close() end
      if text:find("listening on", 1, true) then break end
      if not M.alive(set.pids[name]) then
        set:stop()
        return nil, sformat("the daemon of host %s exited: %s", name, (text:gsub("%s+$", "")))
      end
      if os.time() > deadline then
        set:stop()
        return nil, sformat("the daemon of host %s did not start listening within %gs", name, opts.ready_timeout or 10)
      end
      local sig = core.pending_signal()
      if sig then set:stop() return nil, "interrupted (SIG" .. sig .. ")", "signal" end
      core.sleep(0.01)
    end
  end
  return set
end

function M.alive(pid)
  core.reap(pid)  -- a child of this process that ended: reaped, so it leaves /proc
  local f = io.open("/proc/" .. tostring(pid) .. "/stat", "r")
  if not f then return false end
  local st = f:read("l") or ""
  f:close()
  return not st:match("^%d+ %b() Z")
end

--- Stops the daemons, last started first; waits (bounded) until they are gone from /proc.
function Set:stop(signal)
  for i = #self.order, 1, -1 do
    local pid = self.pids[self.order[i]]
    if pid and M.alive(pid) then core.kill(pid, signal or "TERM") end
  end
  local deadline = os.time() + 5
  for i = #self.order, 1, -1 do
    local pid = self.pids[self.order[i]]
    while pid and M.alive(pid) and os.time() <= deadline do core.sleep(0.02) end
    if pid and M.alive(pid) then core.kill(pid, "KILL") end
  end
  self.order = {}
  if self.own_state then core.remove_tree(self.own_state) self.own_state = nil end
end

return M
