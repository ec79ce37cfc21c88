-- The documents' rules, measured: run by CTest as layout.docs.<rule>, and by hand as
--   dca lua tests/layout/docs.lua [--case RULE]
-- ARCHITECTURE.md is a short map that links every page of docs/; every relative link of README.md,
-- ARCHITECTURE.md and docs/*.md reaches a file of the tree; no document cites an issue number.
local T = require "dca.testing"

local fmt, concat, sort = string.format, table.concat, table.sort

local MAX_MAP_LINES = 400
local root = os.getenv("DCA_SOURCE_DIR") or "."

--- The text of a file of the tree (it must exist).
local function read(path)
  local fh = assert(io.open(root .. "/" .. path))
  local text = fh:read("a")
  fh:close()
  return text
end

--- Whether a path of the tree exists (a file or a folder).
local function exists(path)
  local fh = io.open(root .. "/" .. path)
  if fh then fh:close() return true end
  return false
end

--- The pages of docs/, sorted: {"docs/time.md", ...}.
local function pages()
  local list = {}
  local p = assert(io.popen(fmt("cd '%s' && ls -1 docs 2>/dev/null", root)))
  for name in p:lines() do
    if name:match("%.md$") then list[#list + 1] = "docs/" .. name end
  end
  p:close()
  sort(list)
  return list
end

--- The documents the rules cover.
local function documents()
  local list = { "README.md", "ARCHITECTURE.md" }
  for _, page in ipairs(pages()) do list[#list + 1] = page end
  return list
end

--- The text without fenced code blocks and inline code, whose brackets are no links (line breaks kept).
local function prose(text)
  local blank = function(block) return (block:gsub("[^\n]", "")) end
  return (text:gsub("\n```.-\n```", blank):gsub("`[^`\n]*`", ""))
end

--- Every link target of a Markdown text: {target = "docs/time.md#x", line = n}.
local function links(text)
  local out, line = {}, 1
  for l in (prose(text) .. "\n"):gmatch("([^\n]*)\n") do
    for target in l:gmatch("%]%(([^)%s]+)%)") do out[#out + 1] = { target = target, line = line } end
    line = line + 1
  end
  return out
end

--- The path a relative link names, from the folder of the document it is in; nil for others.
local function resolve(doc, target)
  if target:match("^%a[%w+.-]*:") or target:match("^#") then return nil end
  local path = target:gsub("#.*$", "")
  local dir = doc:match("^(.*)/[^/]+$")
  local parts = {}
  for part in ((dir and dir .. "/" or "") .. path):gmatch("[^/]+") do
    if part == ".." then parts[#parts] = nil elseif part ~= "." then parts[#parts + 1] = part end
  end
  return concat(parts, "/")
end

--- Fails listing every offender, one per line.
local function none(offenders, what)
  if #offenders > 0 then error(fmt("%d %s:\n  %s", #offenders, what, concat(offenders, "\n  ")), 0) end
end

local suite = T.suite("layout.docs")

suite:case("architecture_is_a_short_map", function()
  local _, n = read("ARCHITECTURE.md"):gsub("\n", "")
  T.ok(n < MAX_MAP_LINES, fmt("ARCHITECTURE.md has %d lines; the map stays under %d: move rules to docs/",
                              n, MAX_MAP_LINES))
end)

suite:case("every_docs_page_is_linked_from_architecture", function()
  local linked = {}
  for _, l in ipairs(links(read("ARCHITECTURE.md"))) do
    local path = resolve("ARCHITECTURE.md", l.target)
    if path then linked[path] = true end
  end
  local missing = {}
  for _, page in ipairs(pages()) do
    if not linked[page] then missing[#missing + 1] = page end
  end
  T.ok(#pages() > 0, "docs/ holds the specifications")
  none(missing, "pages of docs/ are not linked from ARCHITECTURE.md")
end)

suite:case("relative_links_reach_existing_files", function()
  local broken = {}
  for _, doc in ipairs(documents()) do
    for _, l in ipairs(links(read(doc))) do
      local path = resolve(doc, l.target)
      if path and not exists(path) then broken[#broken + 1] = fmt("%s:%d: %s", doc, l.line, l.target) end
    end
  end
  none(broken, "links reach no file")
end)

suite:case("no_issue_numbers", function()
  local found = {}
  for _, doc in ipairs(documents()) do
    local line = 1
    for l in (read(doc) .. "\n"):gmatch("([^\n]*)\n") do
      local cite = l:match("[Ii]ssues?%s+#?%d+") or l:match("[Ii]ssues?%s+N%f[%W]")
      if cite then found[#found + 1] = fmt("%s:%d: %s", doc, line, cite) end
      line = line + 1
    end
  end
  none(found, "lines cite an issue: say what is true, not where it came from")
end)

return suite:run(...)
