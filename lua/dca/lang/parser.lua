-- dca.lang.parser: the DCA process-definition language (DCA paper, section 2.1 and appendix), an LPeg grammar.
--
--   local parser = require "dca.lang.parser"
--   local ast, err = parser.parse(text, "door.dca")
--   -- err: "door.dca:12:7: message\n<source line>\n<caret>"; parse never raises, whatever the input.
--
-- The language:
--   use mylab, door;                                      -- the controller packages the file's types come from
--   process Name(param, ...) {
--     host { arg, standby... }                            -- where this group's supervisor runs (then its
--                                                         --   standby hosts, in order: failover)
--     supervision {                                       -- how its supervisor treats its children's faults
--       strategy one_for_one;                             --   one_for_one | one_for_all | rest_for_one
--       intensity 3 in 10 s;                              --   at most N restarts within T (s | ms), then escalate
--       restart on crash, lost;                           --   which faults restart: crash | lost | aborted
--       standby inst on arg, ...;                         --   standby hosts of a leaf instance, in order
--       fence 1.5 s margin 0.5 s;                         --   fencing: leaves stop after T silent (s | ms, s if
--                                                         --   left out); a standby starts after T + margin
--     }
--     instantiated_processes { inst instof Type(arg, ...); ... }
--                                                         -- and templates: `robots instances of Robot(arg, ...)
--                                                         --   on { host, ... };` (instances added at run time,
--                                                         --   each on one host of the set, its first argument)
--     external_io { Alias = inst, Port; ... }             -- an inner port exported under another name
--     internal_connections(inst, label) { a, Out -> b, In; ... }     -- any number of these
--     internal_event_actions { expression }               -- dca.algebra syntax, naming instances
--     verify { property; ... }                            -- properties for `dca check --verify` (dca.verify.props)
--   }
-- Arguments are parameter names, strings ("c1.example"), numbers (30, -0.5, 1e3) or configuration keys
-- (config("door.stop_distance"): the value in the configuration repository, resolved when the system starts).
-- Comments: // and /* */.
-- `use` statements come first (before the first process); a package name is a word (dca.lang.check and
-- dca.load find and load them: ARCHITECTURE.md, "Controller packages").
-- Sections may come in any order; each but internal_connections at most once (dca.lang.check reports repeats).
--
-- AST (every table with `line`, `col` also has `pos`, the byte offset):
--   ast = { file = <name>, source = <text>, index = <dca.lang.source index>,
--           uses = { { name = "mylab", line, col }, ... },     -- every package of every `use`, in order
--           processes = { proc, ... }, by_name = { [name] = proc } (first definition wins) }
--   proc = {
--     name = "DoorOpenSystem", line, col,
--     params = { { name = "host1", line, col }, ... },
--     host = arg | nil,                                  -- the first argument of host { }
--     standby_hosts = { arg, ... },                      -- the others (standby hosts, in order; often empty)
--     supervision = { line, col, clauses = { clause, ... } } | nil,   -- the section, as written (checked by
--       -- dca.lang.check, resolved by dca.lang.model): clause = { kw = "strategy" | "intensity" | "restart" |
--       -- "standby" | "fence", line, col, name (strategy), count, count_line/col, within, unit, unit_line/col
--       -- (intensity), kinds = { { name, line, col }, ... } (restart), instance, instance_line/col, hosts = { arg,
--       -- ... } (standby), within, within_line/col, unit (nil: s), unit_line/col, margin, margin_line/col,
--       -- margin_unit, margin_unit_line/col (fence; margin nil when left out) }
--     rt = { line, col, clauses = { { kw = "priority" | "cpu", value, line, col, value_line/col }, ... } } | nil,
--       -- real time for its leaves' nodes, as written (checked by dca.lang.check; docs/time.md, "Real time")
--     instances = { inst, ...; [name] = inst ... },      -- list in order, and by name (first wins)
--     templates = { tpl, ...; [name] = tpl ... },        -- `name instances of Type(args) on { hosts };` in
--                                                        --   instantiated_processes: tpl = inst's fields (args:
--                                                        --   those written, after the host) and hosts = { arg,
--                                                        --   ... }, on_line/on_col (docs/supervision.md, "A fleet")
--     external_io = { x, ...; [alias] = x ... },         -- x = { alias, instance, port, line, col,
--                                                        --   instance_line/col, port_line/col }
--     internal_connections = { set, ... },               -- set = { instance, label, line, col,
--                                                        --   instance_line, instance_col,
--                                                        --   connections = { { from, out, to, ["in"], line, col,
--                                                        --     out_line/col, to_line/col, in_line/col }, ... } }
--     actions = { text, line, col, expr = <dca.algebra expression> | nil,
--                 error = { msg, line, col } | nil } | nil,   -- expression errors are left to dca.lang.check
--       text: everything between the braces, as written; expr.text: the same with comments blanked out
--       (same length, newlines kept); text_line/text_col: where the text begins (just after '{');
--       line/col: the expression's first token; section_line/section_col: the keyword.
--       Every node of expr.root has its file position (pos, line, col).
--     verify = { text, pos, line, col } | nil,           -- the verify section's text, comments blanked (same
--                                                        --   length), pos: file offset of its first character
--     duplicate_sections = { { section = "host", line, col }, ... },
--   }
--   inst = { name = "hit", type = "HitDetector", line, col, type_line, type_col, args = { arg, ... } }
--   arg  = { kind = "param" | "string" | "number" | "config", value = <name | string | number | key>, line, col }
local lpeg = require "lpeg"
local algebra = require "dca.algebra"
local source = require "dca.lang.source"

local M = {}

local P, R, S, C, Cc, Cg, Ct, Cp, Cb, Cmt, Cs =
  lpeg.P, lpeg.R, lpeg.S, lpeg.C, lpeg.Cc, lpeg.Cg, lpeg.Ct, lpeg.Cp, lpeg.Cb, lpeg.Cmt, lpeg.Cs
local type, error, pcall, tostring, ipairs, pairs, setmetatable, getmetatable =
  type, error, pcall, tostring, ipairs, pairs, setmetatable, getmetatable
local sformat, ssub, sfind, smatch = string.format, string.sub, string.find, string.match

--- The section keywords of a process body.
M.sections = { "host", "instantiated_processes", "external_io", "internal_connections", "internal_event_actions",
               "verify", "supervision", "rt" }
local SECTION = {}
for _, s in ipairs(M.sections) do SECTION[s] = true end

---------------------------------------------------------------------------------------------- lexical

local space = S(" \t\r\n\f\v")
local line_comment = P"//" * (1 - P"\n")^0
local ParseError = {}
local function raise(label, pos, ...)
  error(setmetatable({ label = label, pos = pos, n = select("#", ...), ... }, ParseError), 0)
end
local block_comment = Cmt(Cp() * P"/*" * (1 - P"*/")^0 * (C(P"*/") + Cc(false)), function(_, i, start, closed)
  if not closed then raise("comment", start) end
  return i
end)
local comment = line_comment + block_comment
local ws = (space + comment)^0
local idchar = R("az", "AZ", "09") + "_"
local ident = (R("az", "AZ") + "_") * idchar^0
local NAME = C(ident) * ws
-- A process type: a name, or one qualified by the package that defines it (lab.PD: two packages define PD).
local TYPE_NAME = C(ident * (P"." * ident)^-1) * ws
local function tok(s) return P(s) * ws end
local function kw(w) return P(w) * -idchar * ws end

local digits = R"09"^1
local number = C(P"-"^-1 * digits * (P"." * digits)^-1 * (S"eE" * S"+-"^-1 * digits)^-1) / tonumber * -idchar * ws
local escape = (P"\\" * C(S'"\\')) / "%1" + P"\\n" / "\n" + P"\\t" / "\t"
local string_lit = Cmt(Cp() * P'"' * Cs((escape + (1 - S'"\\\n'))^0) * (C(P'"') + Cc(false)),
                       function(_, i, start, value, closed)
                         if not closed then raise("string", start) end
                         return i, value
                       end) * ws

-- Where a section (or the next process) begins, including the paper's typos "external io",
-- "internal connections": used to tell "missing '}'" from other errors in a list. A keyword counts only
-- when a brace or parenthesis follows, so that `host instof T(h);` still declares an instance "host".
local section_start = (kw"host" + kw"instantiated_processes" + kw"external_io" + kw"internal_event_actions" +
                       kw"verify" + kw"supervision" + kw"rt") * S"{(" +
                      kw"internal_connections" * P"(" + kw"process" * ident * ws * P"(" +
                      (P"external" + P"internal") * -idchar

-- expect(p, label, refs...): p, or else a labelled error at this position; `refs` are names of group
-- captures (Cb) handed to the message function.
local function expect(p, label, ...)
  local refs = { ... }
  local thrower = Cp()
  for _, r in ipairs(refs) do thrower = thrower * Cb(r) end
  return p + Cmt(thrower, function(_, _, pos, ...) raise(label, pos, ...) end)
end

---------------------------------------------------------------------------------------------- grammar

local function pos(name) return Cg(Cp(), name or "pos") end

local config_ref = kw"config" * tok"(" * string_lit * tok")"  -- config("door.stop_distance"): a repository key
local arg = Ct(pos() * (Cg(string_lit, "value") * Cg(Cc"string", "kind") +
                        Cg(number, "value") * Cg(Cc"number", "kind") +
                        Cg(config_ref, "value") * Cg(Cc"config", "kind") +
                        Cg(NAME, "value") * Cg(Cc"param", "kind")))

local args = expect(tok"(", "args_open", "iname", "itype") *
             Ct((arg * (tok"," * expect(arg, "arg"))^0)^-1) *
             expect(tok")", "args_close", "iname")

-- A template (docs/supervision.md, "A fleet"): `name instances of Type(args) on { host, ... };` (or `on host`):
-- instances added and removed while the system runs, each on one host of the set, given as the type's first
-- argument before the written ones.
local template_hosts = tok"{" * Ct(expect(arg, "tpl_host") * (tok"," * expect(arg, "tpl_host"))^0) *
                       expect(tok"}", "tpl_hosts_close") + Ct(arg)
local template_tail = kw"instances" * Cg(Cc(true), "template") * expect(kw"of", "tpl_of", "iname") *
                      pos("type_pos") * Cg(expect(TYPE_NAME, "type_name", "iname"), "type") *
                      Cg(Cb("type"), "itype") * Cg(args, "args") *
                      pos("on_pos") * expect(kw"on", "tpl_on", "iname", "itype") *
                      Cg(expect(template_hosts, "tpl_hosts", "iname"), "hosts") *
                      expect(tok";", "instance_semi", "iname")
local instance = Ct(pos() * -section_start * Cg(NAME, "name") * Cg(Cb("name"), "iname") *
                    (template_tail +
                     expect(kw"instof", "instof", "iname") *
                     pos("type_pos") * Cg(expect(TYPE_NAME, "type_name", "iname"), "type") * Cg(Cb("type"), "itype") *
                     Cg(args, "args") *
                     expect(tok";", "instance_semi", "iname")))

local function section(name, body)
  return Ct(Cg(Cc(name), "section") * pos() * pos("open_" .. name) * kw(name) * body)
end

local host_section = section("host",
  expect(tok"{", "host_open") * Cg(Ct(expect(arg, "host_arg") * (tok"," * expect(arg, "host_arg"))^0), "args") *
  expect(tok"}", "host_close"))

-- supervision { strategy NAME; intensity N in T UNIT; restart on KIND, ...; standby INSTANCE on HOST, ...; }
local kind_name = Ct(pos() * Cg(NAME, "name"))
local period = C(P"-"^-1 * digits * (P"." * digits)^-1) / tonumber * ws  -- its unit may follow at once: 10s
local sup_strategy = Cg(C"strategy", "kw") * -idchar * ws * pos("name_pos") * Cg(expect(NAME, "sup_strategy"), "name")
local sup_intensity = Cg(C"intensity", "kw") * -idchar * ws *
  pos("count_pos") * Cg(expect(number, "sup_count"), "count") * expect(kw"in", "sup_in") *
  pos("within_pos") * Cg(expect(period, "sup_within"), "within") *
  pos("unit_pos") * Cg(expect(NAME, "sup_unit"), "unit")
local sup_restart = Cg(C"restart", "kw") * -idchar * ws * expect(kw"on", "sup_on") *
  Cg(Ct(expect(kind_name, "sup_kind") * (tok"," * expect(kind_name, "sup_kind"))^0), "kinds")
local sup_standby = Cg(C"standby", "kw") * -idchar * ws *
  pos("instance_pos") * Cg(expect(NAME, "sup_instance"), "instance") * expect(kw"on", "sup_standby_on") *
  Cg(Ct(expect(arg, "sup_host") * (tok"," * expect(arg, "sup_host"))^0), "hosts")
-- fence T [UNIT] [margin T [UNIT]]: the unit may be left out (seconds)
local fence_unit = -kw"margin" * NAME
local sup_fence = Cg(C"fence", "kw") * -idchar * ws *
  pos("within_pos") * Cg(expect(period, "sup_fence"), "within") * pos("unit_pos") * Cg(fence_unit, "unit")^-1 *
  (kw"margin" * pos("margin_pos") * Cg(expect(period, "sup_margin"), "margin") *
   pos("margin_unit_pos") * Cg(NAME, "margin_unit")^-1)^-1
local sup_clause = Ct(pos() * -section_start *
                      (sup_strategy + sup_intensity + sup_restart + sup_standby + sup_fence) *
                      expect(tok";", "sup_semi"))
local supervision_section = section("supervision",
  expect(tok"{", "section_open", "section") * Cg(Ct(sup_clause^0), "items") *
  expect(tok"}", "sup_close", "open_supervision"))

-- rt { priority N; cpu N; } (docs/time.md, "Real time")
local rt_clause = Ct(pos() * -section_start * Cg(C"priority" + C"cpu", "kw") * -idchar * ws *
                     pos("value_pos") * Cg(expect(number, "rt_value", "kw"), "value") * expect(tok";", "rt_semi"))
local rt_section = section("rt",
  expect(tok"{", "section_open", "section") * Cg(Ct(rt_clause^0), "items") *
  expect(tok"}", "rt_close", "open_rt"))

local instances_section = section("instantiated_processes",
  expect(tok"{", "section_open", "section") * Cg(Ct(instance^0), "items") *
  expect(tok"}", "section_close", "section", "open_instantiated_processes"))

local xio_entry = Ct(pos() * -section_start * Cg(NAME, "alias") * Cg(Cb("alias"), "xalias") *
                     expect(tok"=", "xio_eq", "xalias") *
                     pos("instance_pos") * Cg(expect(NAME, "xio_instance", "xalias"), "instance") *
                     expect(tok",", "xio_comma", "xalias") *
                     pos("port_pos") * Cg(expect(NAME, "xio_port", "xalias"), "port") *
                     expect(tok";", "xio_semi", "xalias"))
local xio_section = section("external_io",
  expect(tok"{", "section_open", "section") * Cg(Ct(xio_entry^0), "items") *
  expect(tok"}", "section_close", "section", "open_external_io"))

local connection = Ct(pos() * -section_start * Cg(NAME, "from") * expect(tok",", "conn_comma_out") *
                      pos("out_pos") * Cg(expect(NAME, "conn_port_out"), "out") * expect(tok"->", "conn_arrow") *
                      pos("to_pos") * Cg(expect(NAME, "conn_instance_in"), "to") * expect(tok",", "conn_comma_in") *
                      pos("in_pos") * Cg(expect(NAME, "conn_port_in"), "in") * expect(tok";", "conn_semi"))
local ic_section = section("internal_connections",
  expect(tok"(", "ic_paren") * pos("ipos") * Cg(expect(NAME, "ic_instance"), "instance") *
  expect(tok",", "ic_comma") * Cg(expect(NAME, "ic_label"), "label") * expect(tok")", "ic_close_paren") *
  expect(tok"{", "section_open", "section") * Cg(Ct(connection^0), "items") *
  expect(tok"}", "section_close", "section", "open_internal_connections"))

local actions_section = section("internal_event_actions",
  expect(P"{", "section_open", "section") * pos("text_pos") * Cg(C((comment + (1 - S"}"))^0), "text") *
  expect(tok"}", "actions_close", "open_internal_event_actions"))

local verify_section = section("verify",
  expect(P"{", "section_open", "section") * pos("text_pos") * Cg(C((comment + (1 - S"}"))^0), "text") *
  expect(tok"}", "verify_close", "open_verify"))

local any_section = host_section + instances_section + xio_section + ic_section + actions_section + verify_section +
                    supervision_section + rt_section

local param = Ct(pos() * Cg(NAME, "name"))
local process = Ct(pos() * pos("open_process") * kw"process" * Cg(expect(NAME, "process_name"), "name") *
                   Cg(Cb("name"), "pname") *
                   expect(tok"(", "params_open", "pname") *
                   Cg(Ct((param * (tok"," * expect(param, "param", "pname"))^0)^-1), "params") *
                   expect(tok")", "params_close", "pname") *
                   expect(tok"{", "process_open", "pname") *
                   Cg(Ct(any_section^0), "sections") *
                   expect(tok"}", "process_close", "pname", "open_process"))

-- use NAME, NAME...;  (before the first process)
local use_name = Ct(pos() * Cg(NAME, "name"))
local use_stmt = kw"use" * expect(use_name, "use_name") * (tok"," * expect(use_name, "use_name"))^0 *
                 expect(tok";", "use_semi")

local file = ws * Ct(use_stmt^0) * Ct(process^0) * expect(P(-1), "toplevel")

-- For blanking comments out of an expression (keeping offsets and newlines).
local blank = Cs(((comment / function(c) return (c:gsub("[^\n]", " ")) end) + 1)^0)

---------------------------------------------------------------------------------------------- messages

-- What is at `pos`, for "found ..." (a word, a string, a character, or the end of the file).
local function found(s, p)
  if p > #s then return "the end of the file" end
  local w = smatch(s, "^[%a_][%w_]*", p)
  if w then return "'" .. w .. "'" end
  local n = smatch(s, "^%-?%d[%w_.]*", p)
  if n then return "'" .. n .. "'" end
  if ssub(s, p, p) == '"' then return "a string" end
  local c = ssub(s, p, p)
  if c:match("%c") or c:byte() > 126 then return sformat("byte \\%d", c:byte()) end
  return "'" .. c .. "'"
end

-- The section-like words at `pos` ("external iof" -> "external iof", "external_io" -> "external_io").
local function section_words(s, p)
  local w1, sp, w2 = smatch(s, "^([%a_][%w_]*)([ \t]+)([%a_][%w_]*)", p)
  if w1 == "external" or w1 == "internal" then return w1 .. sp .. w2, w1 .. "_" .. w2 end
  local w = smatch(s, "^[%a_][%w_]*", p)
  return w, w
end

local function suggest_section(s, p)
  local shown, joined = section_words(s, p)
  if not shown then return nil end
  if SECTION[joined] then return shown, joined end
  return shown, source.closest(joined, M.sections)
end

local function line_of(idx, p) return (idx:at(p)) end

local function open_line(idx, op) return op and sformat(" (opened at line %d)", line_of(idx, op)) or "" end

-- A '}' missing or a word that is no section, where process `e[1]` (opened at e[2]) should close.
local function process_close(e, f, s, p, idx)
  local shown, guess = suggest_section(s, p)
  if p > #s then return sformat("missing '}' to close process '%s'%s", e[1], open_line(idx, e[2])) end
  if shown == "process" then
    return sformat("missing '}' to close process '%s'%s before the next 'process'", e[1], open_line(idx, e[2]))
  end
  if shown and guess and shown ~= guess and shown:find("[ \t]") then
    return sformat("unknown section '%s': did you mean '%s'? (section names are written with '_')", shown, guess)
  end
  if shown and guess then return sformat("unknown section '%s': did you mean '%s'?", shown, guess) end
  if shown then
    return sformat("unknown section '%s' in process '%s' (sections are: %s)", shown, e[1], table.concat(M.sections, ", "))
  end
  return sformat("expected a section or '}' to close process '%s', found %s", e[1], f)
end

local SECTION_ITEM = {
  instantiated_processes = "expected an instance ('name instof Type(args);') or '}', found ",
  external_io = "expected an export ('Name = instance, Port;') or '}', found ",
  internal_connections = "expected a connection ('a, Out -> b, In;') or '}', found ",
}

-- A '}' missing at the end of section `sec` (opened at op), or an item it cannot hold.
local function section_close(sec, op, f, s, p, idx)
  local shown, guess = suggest_section(s, p)
  if p > #s then return sformat("missing '}' to close '%s'%s", sec, open_line(idx, op)) end
  if shown == "process" or (shown and guess) then
    return sformat("missing '}' to close '%s'%s before '%s'", sec, open_line(idx, op), shown)
  end
  if SECTION_ITEM[sec] then return SECTION_ITEM[sec] .. f end
  return sformat("expected '}' to close '%s', found %s", sec, f)
end

-- Text before the top-level process that cannot start one.
local function toplevel(f, s, p)
  local shown, guess = suggest_section(s, p)
  if shown == "use" then return "'use' comes before the first process (write the file's 'use' statements first)" end
  if shown and (SECTION[guess] or guess) then
    return sformat("'%s' outside a process: a '}' closes the process too early", shown)
  end
  if shown and source.closest(shown, { "process" }) then
    return sformat("expected 'process', found '%s' (did you mean 'process'?)", shown)
  end
  return "expected 'process' to start a process definition, found " .. f
end

-- The message of each label: "label  text", where $1 and $2 stand for the label's captures and $f for what
-- was found.
local MESSAGES = {}
for label, text in ([[
comment           unterminated comment: '/*' without '*/'
string            unterminated string: '"' without a closing '"' on the same line
process_name      expected the process name after 'process', found $f
params_open       expected '(' after 'process $1', found $f
param             expected a parameter name after ',' in process '$1', found $f
params_close      expected ',' or ')' in the parameters of process '$1', found $f
process_open      expected '{' to open process '$1', found $f
host_arg          expected the host in 'host { }': a parameter name or a string, found $f
host_close        expected ',' and a standby host, or '}' after the hosts, found $f
sup_strategy      expected a strategy after 'strategy' (one_for_one, one_for_all or rest_for_one), found $f
sup_count         expected the number of restarts after 'intensity' (write 'intensity 3 in 10 s;'), found $f
sup_in            expected 'in' after the number of restarts (write 'intensity 3 in 10 s;'), found $f
sup_within        expected the period after 'in' (write 'intensity 3 in 10 s;'), found $f
sup_unit          expected the period's unit, s or ms (write 'intensity 3 in 10 s;'), found $f
sup_on            expected 'on' after 'restart' (write 'restart on crash, lost;'), found $f
sup_kind          expected a fault (crash, lost or aborted) in 'restart on', found $f
sup_instance      expected an instance name after 'standby' (write 'standby inst on host2;'), found $f
sup_standby_on    expected 'on' after the instance (write 'standby inst on host2;'), found $f
sup_host          expected a host (a parameter name or a string) in 'standby ... on', found $f
sup_fence         expected the time after 'fence' (write 'fence 1.5 s;' or 'fence 1.5 s margin 0.5 s;'), found $f
sup_margin        expected the time after 'margin' (write 'fence 1.5 s margin 0.5 s;'), found $f
sup_semi          expected ';' to end the supervision clause, found $f
rt_value          expected a whole number after '$1' (write 'rt { priority 80; cpu 1; }'), found $f
rt_semi           expected ';' after the value (write 'rt { priority 80; cpu 1; }'), found $f
section_open      expected '{' after '$1', found $f
instof            expected 'instof' (or 'instances of', a template) after the instance name '$1', found $f
tpl_of            expected 'of' after '$1 instances' (write '$1 instances of Type(args) on { "r1", "r2" };'), found $f
tpl_on            expected 'on' and the hosts of template '$1' (write '$1 instances of $2(args) on { "r1", "r2" };'), found $f
tpl_hosts         expected the hosts of template '$1' after 'on': { "r1", "r2", param } or one host, found $f
tpl_host          expected a host (a parameter name or a string) in the hosts of a template, found $f
tpl_hosts_close   expected ',' and another host, or '}' after the hosts of a template, found $f
type_name         expected a process type after '$1 instof', found $f
args_open         expected '(' after the type '$2' of instance '$1' (write $2() when there are no arguments), found $f
arg               expected an argument after ',' (a parameter name, a string or a number), found $f
args_close        expected ',' or ')' in the arguments of instance '$1', found $f
instance_semi     expected ';' after the instance '$1', found $f
xio_eq            expected '=' after the exported name '$1', found $f
xio_instance      expected an instance name after '$1 =', found $f
xio_comma         expected ',' between the instance and the port (write '$1 = instance, Port;'), found $f
xio_port          expected a port name in the export '$1', found $f
xio_semi          expected ';' after the export '$1', found $f
ic_paren          expected '(' after 'internal_connections' (write internal_connections(instance, label) { ... }), found $f
ic_instance       expected the instance name in internal_connections(instance, label), found $f
ic_comma          expected ',' between the instance and the label in internal_connections(instance, label), found $f
ic_label          expected the label in internal_connections(instance, label), found $f
ic_close_paren    expected ')' after the label in internal_connections(instance, label), found $f
conn_comma_out    expected ',' between instance and port (write 'a, Out -> b, In;'), found $f
conn_comma_in     expected ',' between instance and port (write 'a, Out -> b, In;'), found $f
conn_port_out     expected a port name, found $f
conn_port_in      expected a port name, found $f
conn_arrow        expected '->' between the output and the input (write 'a, Out -> b, In;'), found $f
conn_instance_in  expected the destination instance after '->', found $f
conn_semi         expected ';' after the connection, found $f
use_name          expected a package name after 'use' (write 'use mylab;'), found $f
use_semi          expected ',' and another package, or ';' to end 'use', found $f
]]):gmatch("(%w[%w_]*) +([^\n]+)") do MESSAGES[label] = text end

-- Those that look around the error: function(e, found, text, pos, idx) -> message.
MESSAGES.toplevel = function(_, f, s, p) return toplevel(f, s, p) end
MESSAGES.process_close = process_close
MESSAGES.section_close = function(e, f, s, p, idx) return section_close(e[1], e[2], f, s, p, idx) end
MESSAGES.actions_close = function(e, f, s, p, idx) return section_close("internal_event_actions", e[1], f, s, p, idx) end
MESSAGES.verify_close = function(e, f, s, p, idx) return section_close("verify", e[1], f, s, p, idx) end
function MESSAGES.sup_close(e, f, s, p, idx)
  local w = smatch(s, "^[%a_][%w_]*", p)
  if w and not SECTION[w] and w ~= "process" then
    local guess = source.closest(w, { "strategy", "intensity", "restart", "standby", "fence" })
    return sformat("unknown supervision clause '%s'%s (clauses: strategy, intensity, restart, standby, fence)", w,
                   guess and sformat(": did you mean '%s'?", guess) or "")
  end
  return section_close("supervision", e[1], f, s, p, idx)
end
function MESSAGES.rt_close(e, f, s, p, idx)
  local w = smatch(s, "^[%a_][%w_]*", p)
  if w and not SECTION[w] and w ~= "process" then
    return sformat("unknown rt clause '%s' (clauses: priority, cpu; write 'rt { priority 80; cpu 1; }')", w)
  end
  return section_close("rt", e[1], f, s, p, idx)
end
function MESSAGES.host_open(_, f, s, p)
  if ssub(s, p, p) ~= "(" then return "expected '{' after 'host', found " .. f end
  return sformat("'host' takes braces, not parentheses: write 'host { %s }'", smatch(s, "^%(%s*([^%s%)]*)", p) or "")
end

-- Builds the message of a labelled error: returns message, position.
local function message(e, s, idx)
  local f, text = found(s, e.pos), MESSAGES[e.label]
  if not text then return "syntax error (" .. tostring(e.label) .. "), found " .. f, e.pos end
  if type(text) == "function" then return text(e, f, s, e.pos, idx), e.pos end
  return (text:gsub("%$(%w)", { ["1"] = tostring(e[1]), ["2"] = tostring(e[2]), f = f })), e.pos
end

---------------------------------------------------------------------------------------------- AST


local function clean(t, keys)
  for _, k in ipairs(keys) do t[k] = nil end
end

-- Each section kind into the process's fields: BUILD[kind](proc, sec, idx) (positions as line/col by idx.set).
local BUILD = {}

function BUILD.host(proc, sec, idx)
  for _, a in ipairs(sec.args) do idx.set(a, a.pos) end
  proc.host = sec.args[1]
  for i = 2, #sec.args do proc.standby_hosts[i - 1] = sec.args[i] end
  proc.host_line, proc.host_col = idx:at(sec.pos)
end

-- Line and column of each position field of t: pos -> line, col; X_pos -> X_line, X_col.
local function locate(idx, t, ...)
  for _, field in ipairs({ ... }) do
    local stem = field:match("^(.*)_pos$")
    idx.set(t, t[field], stem and stem .. "_line" or "line", stem and stem .. "_col" or "col")
  end
end

function BUILD.supervision(proc, sec, idx)
  local sup = { pos = sec.pos, clauses = {} }
  idx.set(sup, sec.pos)
  for i, cl in ipairs(sec.items) do
    local fields = {}
    for k in pairs(cl) do if k:match("_pos$") or k == "pos" then fields[#fields + 1] = k end end
    locate(idx, cl, table.unpack(fields))
    for _, x in ipairs(cl.kinds or cl.hosts or {}) do idx.set(x, x.pos) end
    sup.clauses[i] = cl
  end
  proc.supervision = sup
end

function BUILD.rt(proc, sec, idx)
  local rt = { clauses = {} }
  idx.set(rt, sec.pos)
  for i, cl in ipairs(sec.items) do
    locate(idx, cl, "pos", "value_pos")
    rt.clauses[i] = cl
  end
  proc.rt = rt
end

-- Appends item to list, reachable by name too (the first of a name wins).
local function add_named(list, item, name)
  list[#list + 1] = item
  if list[name] == nil then list[name] = item end
end

function BUILD.instantiated_processes(proc, sec, idx)
  for _, inst in ipairs(sec.items) do
    clean(inst, { "iname", "itype" })
    locate(idx, inst, "pos", "type_pos")
    for _, a in ipairs(inst.args) do locate(idx, a, "pos") end
    if inst.template then
      locate(idx, inst, "on_pos")
      for _, a in ipairs(inst.hosts) do locate(idx, a, "pos") end
      inst.template = nil
      add_named(proc.templates, inst, inst.name)
    else
      add_named(proc.instances, inst, inst.name)
    end
  end
end

function BUILD.external_io(proc, sec, idx)
  for _, x in ipairs(sec.items) do
    clean(x, { "xalias" })
    locate(idx, x, "pos", "instance_pos", "port_pos")
    add_named(proc.external_io, x, x.alias)
  end
end

function BUILD.internal_connections(proc, sec, idx)
  local set = { instance = sec.instance, label = sec.label, pos = sec.pos, connections = {} }
  locate(idx, set, "pos")
  set.instance_line, set.instance_col = idx:at(sec.ipos)
  for i, cn in ipairs(sec.items) do
    locate(idx, cn, "pos", "out_pos", "to_pos", "in_pos")
    set.connections[i] = cn
  end
  proc.internal_connections[#proc.internal_connections + 1] = set
end

-- The expression's nodes moved to file coordinates (the text starts at offset `base` of the file).
local function place(nd, base, idx)
  nd.pos = nd.pos + base - 1
  if nd.stop then nd.stop = nd.stop + base - 1 end
  nd.line, nd.col = idx:at(nd.pos)
  if nd.kids then for _, k in ipairs(nd.kids) do place(k, base, idx) end end
end

function BUILD.internal_event_actions(proc, sec, idx)
  local at = idx.set
  local act = { text = sec.text, pos = sec.text_pos }
  at(act, sec.pos, "section_line", "section_col")
  at(act, sec.text_pos, "text_line", "text_col")
  -- the expression's position: its first token (or the text start when blank)
  local body = blank:match(sec.text)
  local lead = sfind(body, "[^%s]")
  at(act, sec.text_pos + ((lead or 1) - 1))
  local expr, _, info = algebra.parse(body)
  if expr then
    place(expr.root, sec.text_pos, idx)
    act.expr = expr
  else
    local p = info.msg == "empty expression" and sec.pos or sec.text_pos + info.pos - 1
    local l, c = idx:at(p)
    act.error = { msg = info.msg, pos = p, line = l, col = c }
  end
  proc.actions = act
end

function BUILD.verify(proc, sec, idx)
  proc.verify = { text = blank:match(sec.text), pos = sec.text_pos }
  idx.set(proc.verify, sec.pos)
end

local function build_process(raw, idx)
  local proc = { name = raw.name, pos = raw.pos, params = {}, instances = {}, templates = {}, external_io = {},
                 internal_connections = {}, duplicate_sections = {}, standby_hosts = {} }
  idx.set(proc, raw.pos)
  for i, prm in ipairs(raw.params) do
    proc.params[i] = prm
    idx.set(prm, prm.pos)
  end
  local seen = {}
  for _, sec in ipairs(raw.sections) do
    local kind, spos = sec.section, sec.pos
    if kind ~= "internal_connections" and seen[kind] then
      local l, c = idx:at(spos)
      proc.duplicate_sections[#proc.duplicate_sections + 1] = { section = kind, pos = spos, line = l, col = c,
                                                                 first_line = seen[kind] }
    else
      seen[kind] = (idx:at(spos))
      if BUILD[kind] then BUILD[kind](proc, sec, idx) end
    end
  end
  return proc
end

--- Parses DCA source text. Returns the AST (see the top of this file), or nil and
--- "file:line:col: message\n<source line>\n<caret>". Never raises.
function M.parse(text, filename)
  filename = filename or "<input>"
  if type(text) ~= "string" then
    return nil, sformat("%s:1:1: expected the source text as a string, got %s", tostring(filename), type(text))
  end
  local idx = source.index(text)
  local ok, raw, raw_procs = pcall(lpeg.match, file, text)
  if not ok then
    if getmetatable(raw) == ParseError then
      local okm, msg, p = pcall(message, raw, text, idx)
      if not okm then msg, p = "syntax error (" .. tostring(msg) .. ")", raw.pos end
      if p > #text then
        -- at the end of the file: point just after the last token
        p = (sfind(text, "[^%s]%s*$") or 0) + 1
        if p < 1 then p = 1 end
      end
      local line, col = idx:at(p)
      return nil, source.format(filename, idx, line, col, msg)
    end
    local m = tostring(raw)
    if m:find("stack overflow", 1, true) or m:find("too complex", 1, true) then
      return nil, source.format(filename, idx, 1, 1, "input too complex to parse (" .. m .. ")")
    end
    return nil, source.format(filename, idx, 1, 1, "internal parser error: " .. m)
  end
  local ast = { file = filename, source = text, index = idx, uses = {}, processes = {}, by_name = {} }
  local okb, err = pcall(function()
    for i, u in ipairs(raw) do
      ast.uses[i] = { name = u.name, pos = u.pos }
      idx.set(ast.uses[i], u.pos)
    end
    for i, rp in ipairs(raw_procs) do
      local proc = build_process(rp, idx)
      ast.processes[i] = proc
      if ast.by_name[proc.name] == nil then ast.by_name[proc.name] = proc end
    end
  end)
  if not okb then return nil, source.format(filename, idx, 1, 1, "internal parser error: " .. tostring(err)) end
  return ast
end

--- The process named `name` in `ast` (the first definition), or nil.
function M.process(ast, name)
  for _, p in ipairs(ast.processes) do
    if p.name == name then return p end
  end
  return nil
end

--- Formats an error at (line, col) of the parsed file, like parse errors.
function M.format_error(ast, line, col, msg)
  return source.format(ast.file, ast.index, line, col, msg)
end

return M
