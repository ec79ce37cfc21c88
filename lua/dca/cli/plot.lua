-- `dca plot FILE.mcap|FILE.csv`: a recording's signals drawn with gnuplot, one panel per topic, sampled signals
-- as steps, the run's steps (its processes starting, from /dca/events) marked.
local args = require "dca.cli.args"

local M = {}

local sformat, concat, ipairs, tostring, tonumber = string.format, table.concat, ipairs, tostring, tonumber

M.summary = "draw a recording (`dca sim`/`dca run --record`) to a PNG with gnuplot: chosen signals, steps marked"
M.usage = [[usage: dca plot FILE.mcap|FILE.csv [-o FILE.png] [--signal PATTERN]... [--list] [--script FILE]

Draws a recording made by `dca sim --record FILE` or `dca run ... --record FILE [--record-ports ...]` (MCAP or
CSV) to a PNG (default: FILE.png) with gnuplot, one panel per topic. A signal is TOPIC[i] or TOPIC.FIELD: the
world's (/world/door/angle[0], /world/wrist/wrench[0], ...; the groups of `dca sim`'s own recording:
/world/door.door_angle) and the recorded ports' (/main/arm/pd/Out for a scalar, /main/arm/pd/Out[0] for a
vector's first value, /main/arm/js/Joints.position[0] and .header.stamp.sec for a
message port's fields, of either recording profile); a CSV's are its columns. The ports' and the world's sampled
signals are drawn as steps (a value holds until the next sample); the run's steps (processes starting, from
/dca/events) are marked with dashed lines and the processes' names.

  --signal PATTERN  draw the signals matching PATTERN (`*` any text; repeatable); default: the signals the
                    default world chooses (its descriptor's `plot`: the door's angles, wrist force and base
                    position) when recorded, else every signal
  --list            print the recording's signals (with their sample counts) and the steps, draw nothing
  --script FILE     write the gnuplot script to FILE and its data to FILE.dat instead of running gnuplot
Needs gnuplot (scripts/setup installs gnuplot-nox).]]

local MAX_BYTES = 1 << 30  -- as `dca monitor` reads at most (bindings/wrap_mcap.cpp)
local MAX_MARKS = 40       -- step marks drawn at most (a run with more marks its first ones)

local function fail(msg) io.stderr:write("dca plot: ", msg, "\n") return 1 end

local function size_of(file)
  local f = io.open(file, "rb")
  if not f then return nil end
  local n = f:seek("end")
  f:close()
  return n
end

-- The series of a recording: { list = { { name, topic, t = {}, v = {} } ... }, steps = { { t, path } } }.
local function series_table()
  local s = { list = {}, by = {}, steps = {} }
  function s.add(topic, name, t, v)
    local e = s.by[name]
    if not e then
      e = { name = name, topic = topic, t = {}, v = {} }
      s.by[name] = e
      s.list[#s.list + 1] = e
    end
    e.t[#e.t + 1], e.v[#e.v + 1] = t, v
  end
  return s
end

-- Adds the numbers of a decoded sample `x` as series named from `name`: a vector's as name[i], a message's fields
-- as name.field (nested: name.header.stamp.sec, name.position[0]), in name order; strings and nulls are left out.
local function add_numbers(s, topic, name, t, x, depth)
  if type(x) == "number" then return s.add(topic, name, t, x) end
  if type(x) ~= "table" or depth > 8 then return end
  if #x > 0 then
    for i, y in ipairs(x) do add_numbers(s, topic, sformat("%s[%d]", name, i - 1), t, y, depth + 1) end
    return
  end
  local keys = {}
  for k in pairs(x) do if type(k) == "string" then keys[#keys + 1] = k end end
  table.sort(keys)
  for _, k in ipairs(keys) do add_numbers(s, topic, name .. "." .. k, t, x[k], depth + 1) end
end

-- Each JSON channel's units, from its JSON Schema as a port's or world signal's recording writes it (tap::json_schema:
-- the value's, or its items', description: "rad", "m/s, m/s, rad/s"). --> { [topic] = { text =, size = } }
local function units_of(channels)
  local core = require "dca.core"
  local out = {}
  for _, ch in pairs(channels) do
    local ok, js = pcall(core.json_decode, ch.schema_data or "")
    local v = ok and type(js) == "table" and type(js.properties) == "table" and js.properties.value
    if type(v) == "table" then
      local d = type(v.items) == "table" and v.items.description or v.description
      if type(d) == "string" and d ~= "" then out[ch.topic] = { text = d, size = tonumber(v.maxItems) } end
    end
  end
  return out
end

--- The unit of series `name` of `topic` given its topic's units `u`: the i-th of a list with one per element
--- ("m/s, m/s, rad/s" for name[1]: "m/s"), else the whole text; nil when unknown.
function M.unit_of(u, topic, name)
  if not u then return nil end
  local i = tonumber(name:sub(#topic + 1):match("^%[(%d+)%]$"))
  local parts = {}
  for p in (u.text .. ","):gmatch("%s*([^,]-)%s*,") do parts[#parts + 1] = p end
  if i and u.size and u.size > 1 and #parts == u.size then return parts[i + 1] end
  return u.text
end

local function read_mcap(file)
  local core = require "dca.core"
  local rec, err = core.mcap_read(file)
  if not rec then return nil, tostring(err) end
  local s = series_table()
  s.units = units_of(rec.channels)
  for _, m in ipairs(rec.messages) do
    local ch = rec.channels[m.channel]
    local topic = ch and ch.topic
    local t = (tonumber(m.t) or 0) / 1e9
    if topic == "/dca/events" then
      local ok, e = pcall(core.json_decode, m.data)
      if ok and type(e) == "table" and e.state == "running" and type(e.path) == "string" then
        s.steps[#s.steps + 1] = { t = tonumber(e.t) or t, path = e.path }
      end
    elseif topic and topic:sub(1, 5) ~= "/dca/" and m.data:sub(1, 1) == "{" then
      local ok, v = pcall(core.json_decode, m.data)
      if ok and type(v) == "table" then
        -- a port's sample { "value": x | [x...] | {message fields} } (a ros2 profile's CDR is decoded to the
        -- same by core.mcap_read), or a world group's fields { "q1": x, ... } in name order
        local val = v.value
        if type(val) == "number" or type(val) == "table" then
          add_numbers(s, topic, topic, t, val, 0)
        else
          local names = {}
          for k, x in pairs(v) do if type(x) == "number" then names[#names + 1] = k end end
          table.sort(names)
          for _, k in ipairs(names) do s.add(topic, topic .. "." .. k, t, v[k]) end
        end
      end
    end
  end
  return s
end

local function read_csv(file)
  local f, err = io.open(file, "r")
  if not f then return nil, tostring(err) end
  local header = f:read("l")
  if not header or not header:match("^[%w_]+,") then f:close() return nil, "no CSV header line" end
  local cols = {}
  for name in header:gmatch("[^,]+") do cols[#cols + 1] = name end
  local s, n = series_table(), 1
  for line in f:lines() do
    n = n + 1
    local vals = {}
    for x in line:gmatch("[^,]+") do vals[#vals + 1] = tonumber(x) end
    if #vals ~= #cols then f:close() return nil, sformat("line %d: %d numbers for %d columns", n, #vals, #cols) end
    for i = 2, #cols do s.add("csv", cols[i], vals[1], vals[i]) end
  end
  f:close()
  return s
end

-- `*` any text; the rest as written.
local function glob(pattern)
  return "^" .. pattern:gsub("[%^%$%(%)%%%.%[%]%+%-%?]", "%%%0"):gsub("%*", ".*") .. "$"
end

local function choose(s, patterns)
  local chosen, seen = {}, {}
  for _, p in ipairs(patterns) do
    local g, any = glob(p), false
    for _, e in ipairs(s.list) do
      if e.name:match(g) then
        any = true
        if not seen[e.name] then seen[e.name] = true chosen[#chosen + 1] = e end
      end
    end
    if not any and not patterns.default then return nil, sformat("no signal matches '%s' (--list lists them)", p) end
  end
  return chosen
end

local function q(s) return "'" .. tostring(s):gsub("'", "''") .. "'" end

-- The data (one gnuplot index block per series) and the script that draws them to `png`.
local function script_of(chosen, steps, data, png, title, units)
  units = units or {}
  local blocks = {}
  for i, e in ipairs(chosen) do
    local rows = { "# " .. e.name }
    for j = 1, #e.t do rows[#rows + 1] = sformat("%.9g %.17g", e.t[j], e.v[j]) end
    blocks[i] = concat(rows, "\n")
  end
  local panels, order = {}, {}
  for i, e in ipairs(chosen) do
    if not panels[e.topic] then panels[e.topic] = {} order[#order + 1] = e.topic end
    local p = panels[e.topic]
    local unit = M.unit_of(units[e.topic], e.topic, e.name)  -- (from the recording's schema: the manifest's)
    p[#p + 1] = { index = i - 1, name = unit and sformat("%s (%s)", e.name, unit) or e.name }
  end
  local lines = {
    sformat("set terminal pngcairo size 1200,%d noenhanced", math.max(400, 300 * #order)),
    "set output " .. q(png),
    "set grid",
    "set key outside right top",
    "set xlabel 'simulated time (s)'",
    sformat("set multiplot layout %d,1 title %s", #order, q("dca plot: " .. title)),
  }
  -- the run's steps: a dashed line at each time processes start, labelled with the names of the outermost of
  -- them (a process whose group starts with it is left out)
  local times, at = {}, {}
  for _, st in ipairs(steps) do
    if not at[st.t] then at[st.t] = {} times[#times + 1] = st.t end
    local list = at[st.t]
    list[#list + 1] = st.path
  end
  local marks = {}
  for i, t in ipairs(times) do
    if i > MAX_MARKS then break end
    local starting, names = {}, {}
    for _, path in ipairs(at[t]) do starting[path] = true end
    for _, path in ipairs(at[t]) do
      if not starting[path:match("^(.*)%.[^.]+$") or ""] then names[#names + 1] = path:match("[^.]+$") end
    end
    marks[#marks + 1] = sformat("set arrow from %.9g, graph 0 to %.9g, graph 1 nohead dt 2 lc rgb '#888888'", t, t)
    marks[#marks + 1] = sformat("set label %s at %.9g, graph 0.98 rotate by 90 right font ',7' tc rgb '#666666'",
                                q(concat(names, ", ")), t)
  end
  for _, topic in ipairs(order) do
    lines[#lines + 1] = "set title " .. q(topic)
    for _, m in ipairs(marks) do lines[#lines + 1] = m end
    local parts = {}
    for _, p in ipairs(panels[topic]) do
      parts[#parts + 1] = sformat("%s index %d using 1:2 with steps lw 1.5 title %s", #parts == 0 and q(data) or "''",
                                  p.index, q(p.name))
    end
    lines[#lines + 1] = "plot " .. concat(parts, ", ")
    lines[#lines + 1] = "unset arrow; unset label"
  end
  lines[#lines + 1] = "unset multiplot"
  return concat(blocks, "\n\n\n") .. "\n", concat(lines, "\n") .. "\n"
end

local function write(path, text)
  local f, err = io.open(path, "w")
  if not f then return nil, tostring(err) end
  f:write(text)
  f:close()
  return true
end

function M.main(argv)
  local o, err = args.parse(argv, "dca plot", { ["-o"] = "value:out", ["--output"] = "value:out",
    ["--signal"] = "list", ["--list"] = "flag", ["--script"] = "value" })
  if not o then return args.usage_error(err, M.usage) end
  local file = o[1]
  if not file then io.stderr:write(M.usage, "\n") return 2 end
  local size = size_of(file)
  if not size then return fail(file .. ": cannot open the recording") end
  if size > MAX_BYTES then return fail(sformat("%s: %d bytes: dca plot reads recordings of at most 1 GiB", file, size)) end
  local mcap = file:match("%.mcap$") ~= nil
  local s, rerr = (mcap and read_mcap or read_csv)(file)
  if not s then return fail(file .. ": " .. rerr) end
  if #s.list == 0 then return fail(file .. ": no signals (not a recording of dca sim or dca run --record)") end
  if o.list then
    for _, e in ipairs(s.list) do io.stdout:write(sformat("%s  %d samples\n", e.name, #e.t)) end
    for _, st in ipairs(s.steps) do io.stdout:write(sformat("step %.3f s  %s\n", st.t, st.path)) end
    return 0
  end
  local chosen, cerr
  if o.signal then
    chosen, cerr = choose(s, o.signal)
  else
    -- the default world's choice (its descriptor's `plot`) when the recording has any of it, else everything
    local ok, d = pcall(function() return require("dca.worlds").descriptor() end)
    local mine = ok and type(d.plot) == "table" and choose(s, table.move(d.plot, 1, #d.plot, 1, { default = true }))
    chosen = (mine and #mine > 0) and mine or choose(s, { "*" })
  end
  if not chosen then return fail(cerr) end
  local png = o.out or (file:gsub("%.mcap$", ""):gsub("%.csv$", "") .. ".png")
  local script_path = o.script or (png .. ".gnuplot")
  local data_path = script_path .. ".dat"
  local data, script = script_of(chosen, s.steps, data_path, png, file, s.units)
  local ok, werr = write(data_path, data)
  if ok then ok, werr = write(script_path, script) end
  if not ok then os.remove(data_path) return fail(werr) end
  if o.script then
    io.stdout:write(script_path, "\n")
    return 0
  end
  local p = io.popen("gnuplot '" .. script_path:gsub("'", "'\\''") .. "' 2>&1")
  local out = p and p:read("a") or ""
  local done = p and p:close()
  os.remove(script_path)
  os.remove(data_path)
  if not p then return fail("cannot run gnuplot (is it installed? scripts/setup installs gnuplot-nox)") end
  if not done or (size_of(png) or 0) == 0 then return fail(png .. ": gnuplot failed: " .. out) end
  io.stdout:write(png, "\n")
  return 0
end

return M
