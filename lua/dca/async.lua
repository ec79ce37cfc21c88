-- dca.async: the three shapes of callback code the Lua side repeats: a join of several answers, a list worked
-- through one item at a time, and a request's reply read as a success or a reason. Pure: no loop, no clock.
--
--   local j = async.join(cb, fail_fast)  -- j.add() --> a callback k(ok, err), to be called once; j.close() once
--                                        --   every k is added. cb(true) once all are called with ok; with a
--                                        --   failure cb(nil, first err): at once with fail_fast, else once all
--                                        --   are called. cb runs once; j.over() says whether it ran.
--   async.each_in_order(list, fn, done)  -- fn(item, i, next) for each item in turn, next() going on to the next;
--                                        --   done() after the last. An fn that does not call next stops there.
--   async.outcome(reply, err)            --> reply | nil, reason (an error reply's reason, or err: no reply;
--                                        --   never nil: "no answer" when there is neither)
local M = {}

local tostring = tostring

function M.join(cb, fail_fast)
  local j, left, failure, over = {}, 1, nil, false
  local function settle(ok, err)
    if over then return end
    if not ok and failure == nil then
      failure = err == nil and "failed" or err
      if fail_fast then over = true cb(nil, failure) return end
    end
    left = left - 1
    if left > 0 then return end
    over = true
    if failure ~= nil then cb(nil, failure) else cb(true) end
  end
  function j.add()
    left = left + 1
    local called = false
    return function(ok, err)
      if called then return end
      called = true
      settle(ok, err)
    end
  end
  function j.close() settle(true) end
  function j.over() return over end
  return j
end

function M.each_in_order(list, fn, done)
  local function step(i)
    if i > #list then if done then done() end return end
    fn(list[i], i, function() step(i + 1) end)
  end
  step(1)
end

function M.outcome(reply, err)
  if reply and reply.type ~= "error" then return reply end
  if reply then return nil, tostring(reply.reason or "an error reply without a reason") end
  return nil, err ~= nil and tostring(err) or "no answer"
end

return M
