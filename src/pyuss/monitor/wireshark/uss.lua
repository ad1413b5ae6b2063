-- USS (Siemens "Universal Serial Interface") dissector for Wireshark, shipped with pyuss.
--
-- Decodes the pcapng captures `uss monitor --write FILE.pcapng` writes: one packet per frame
-- on the line, with a user link type (LINKTYPE_USER0 = 147 unless chosen otherwise; set the
-- "User link type" preference of the USS protocol to match) and this packet layout:
--
--   offset size  pseudo-header (big endian), written by pyuss.monitor.capture
--   0      1     version (1)
--   1      1     header length in bytes (20; 16 in captures of earlier versions); the
--                telegram follows at this offset
--   2      1     direction: 0 unknown, 1 request (master to slave), 2 response (slave to master)
--   3      1     receive fault (A 5.2.2): 0 framing, 1 overrun, 2 parity, 3 no valid start,
--                4 BCC, 5 residual time, 6 LGE, 8 undefined ADR, 255 none
--   4      2     flags (see FLAGS below)
--   6      1     PKW words of the layout used: 0, 3, 4, 127 (variable), 255 unknown
--   7      1     PZD words of the layout used: 0..16, 255 unknown
--   8      4     duration of the frame in microseconds
--   12     4     response delay of an answer in microseconds (signed; -2^31: none)
--   16     4     nanoseconds of the duration beyond its whole microseconds (0..999)
--   20     ...   the bytes as they were on the line: STX LGE ADR net data BCC
--
-- Install: `uss wireshark install` copies this file into Wireshark's personal Lua plugins
-- folder; or load it once with `wireshark -X lua_script:/path/to/uss.lua`.
-- Sections cited: USS specification part A (telegram, A 4) and part C (net data, C 4 and C 5).
-- Only arithmetic is used for bit work, so the script runs with Lua 5.1 to 5.4.

local uss = Proto("uss", "USS (Universal Serial Interface)")

local DIRECTIONS = {
    [0] = "unknown",
    [1] = "request (master to slave)",
    [2] = "response (slave to master)",
}
local FAULTS = {
    [0] = "framing error",
    [1] = "overrun",
    [2] = "parity error",
    [3] = "no valid start (no STX after a start pause)",
    [4] = "wrong BCC",
    [5] = "residual time exceeded",
    [6] = "wrong LGE",
    [8] = "undefined ADR bits",
    [255] = "none",
}
local FLAG_NAMES = {
    { 0x0001, "guessed_direction", "Direction from timing and position (2-wire line)" },
    { 0x0002, "unsure", "Pairing is a guess" },
    { 0x0004, "layout_given", "Layout given by the user" },
    { 0x0008, "layout_guessed", "Layout is a guess" },
    { 0x0010, "no_answer", "No answer within the response delay limit" },
    { 0x0020, "late_answer", "Answer after the response delay limit" },
    { 0x0040, "early_answer", "Answer sooner than the start pause" },
    { 0x0080, "wrong_address", "Answer from the wrong address" },
    { 0x0100, "unexpected", "Answer nobody asked for" },
    { 0x0200, "mirror", "Mirror answer differs from the request" },
    { 0x0400, "layout", "Net data do not fit the layout" },
    { 0x0800, "port_1", "Received on the second port (4-wire)" },
}
local MODES = {
    [0x00] = "normal",
    [0x40] = "mirror",
    [0x20] = "broadcast",
    [0x80] = "special",
    [0xA0] = "special broadcast",
}
local MODE_BITS = {}  -- the same by ADR bits 7..5 as a number (a masked field is shifted)
for value, name in pairs(MODES) do MODE_BITS[value / 32] = name end
local REQUESTS = {
    [0] = "no job",
    [1] = "read parameter value",
    [2] = "write parameter value (word)",
    [3] = "write parameter value (double word)",
    [4] = "read description element",
    [5] = "write description element",
    [6] = "read array element",
    [7] = "write array element (word)",
    [8] = "write array element (double word)",
    [9] = "read array length",
    [10] = "reserved",
    [11] = "write array element (double word) and store in EEPROM",
    [12] = "write array element (word) and store in EEPROM",
    [13] = "write parameter value (double word) and store in EEPROM",
    [14] = "write parameter value (word) and store in EEPROM",
    [15] = "read or write text",
}
local RESPONSES = {
    [0] = "no response",
    [1] = "parameter value (word)",
    [2] = "parameter value (double word)",
    [3] = "description element",
    [4] = "array element (word)",
    [5] = "array element (double word)",
    [6] = "array length",
    [7] = "job refused (error number in PWE)",
    [8] = "no parameter change rights",
    [9] = "spontaneous message (word)",
    [10] = "spontaneous message (double word)",
    [11] = "spontaneous message (array word)",
    [12] = "spontaneous message (array double word)",
    [13] = "reserved",
    [14] = "reserved",
    [15] = "text",
}
local ERRORS = {
    [0] = "illegal parameter number",
    [1] = "parameter cannot be changed",
    [2] = "lower or upper limit exceeded",
    [3] = "wrong index",
    [4] = "parameter is not an array",
    [5] = "wrong data type",
    [6] = "setting not allowed",
    [7] = "description element cannot be changed",
}
local CONTROL_BITS = {
    "ON (0: OFF1)", "no OFF2 (0: coast stop)", "no OFF3 (0: quick stop)", "enable operation",
    "ramp generator enabled", "ramp generator running", "setpoint enabled",
    "acknowledge fault", "jog 1", "jog 2", "control by PLC",
}
local STATUS_BITS = {
    "ready to switch on", "ready to operate", "operation enabled", "fault",
    "no OFF2", "no OFF3", "switch-on inhibited", "warning", "actual value in tolerance",
    "control requested", "comparison value reached",
}
local DWORD_REQUESTS = { [3] = true, [8] = true, [11] = true, [13] = true }
local DWORD_RESPONSES = { [2] = true, [5] = true, [10] = true, [12] = true }
local READ_REQUESTS = { [1] = true, [4] = true, [6] = true, [9] = true }
local INDEXED_REQUESTS = { [4] = true, [5] = true, [6] = true, [7] = true, [8] = true,
    [11] = true, [12] = true, [15] = true }
local INDEXED_RESPONSES = { [3] = true, [4] = true, [5] = true, [11] = true, [12] = true,
    [15] = true }

local f = uss.fields
f.version = ProtoField.uint8("uss.capture.version", "Pseudo-header version")
f.header_length = ProtoField.uint8("uss.capture.header_length", "Pseudo-header length")
f.direction = ProtoField.uint8("uss.direction", "Direction", base.DEC, DIRECTIONS)
f.fault = ProtoField.uint8("uss.fault", "Receive fault", base.DEC, FAULTS)
f.flags = ProtoField.uint16("uss.flags", "Flags", base.HEX)
local flag_fields = {}
for i, item in ipairs(FLAG_NAMES) do
    flag_fields[i] = ProtoField.bool("uss.flags." .. item[2], item[3], 16, nil, item[1])
    f["flag_" .. item[2]] = flag_fields[i]
end
local PKW_COUNTS = { [0] = "0", [3] = "3", [4] = "4", [127] = "variable", [255] = "unknown" }
local PZD_COUNTS = { [255] = "unknown" }
for i = 0, 16 do PZD_COUNTS[i] = tostring(i) end
f.layout_pkw = ProtoField.uint8("uss.layout.pkw", "Layout PKW words", base.DEC, PKW_COUNTS)
f.layout_pzd = ProtoField.uint8("uss.layout.pzd", "Layout PZD words", base.DEC, PZD_COUNTS)
f.duration = ProtoField.uint32("uss.duration", "Duration (microseconds)")
f.delay = ProtoField.int32("uss.delay", "Response delay (microseconds)")

f.stx = ProtoField.uint8("uss.stx", "STX", base.HEX)
f.lge = ProtoField.uint8("uss.lge", "LGE", base.DEC)
f.adr = ProtoField.uint8("uss.adr", "ADR", base.HEX)
f.address = ProtoField.uint8("uss.address", "Address", base.DEC, nil, 0x1F)
f.mode = ProtoField.uint8("uss.mode", "Telegram type (ADR bits 7..5)", base.DEC, MODE_BITS, 0xE0)
f.net = ProtoField.bytes("uss.net", "Net data")
f.bcc = ProtoField.uint8("uss.bcc", "BCC", base.HEX)
f.bcc_ok = ProtoField.bool("uss.bcc.ok", "BCC correct")
f.bcc_expected = ProtoField.uint8("uss.bcc.expected", "BCC expected", base.HEX)

f.pkw = ProtoField.bytes("uss.pkw", "PKW (parameter channel)")
f.pke = ProtoField.uint16("uss.pke", "PKE", base.HEX)
f.request_id = ProtoField.uint16("uss.pke.request", "Request ID", base.DEC, REQUESTS, 0xF000)
f.response_id = ProtoField.uint16("uss.pke.response", "Response ID", base.DEC, RESPONSES, 0xF000)
f.id = ProtoField.uint16("uss.pke.id", "Request/response ID (direction unknown)", base.DEC, nil, 0xF000)
f.toggle = ProtoField.uint16("uss.pke.toggle", "Spontaneous message toggle", base.DEC, nil, 0x0800)
f.pnu = ProtoField.uint16("uss.pnu", "PNU", base.DEC, nil, 0x07FF)
f.parameter = ProtoField.uint16("uss.parameter", "Parameter number (PNU + IND page)", base.DEC)
f.ind = ProtoField.uint16("uss.ind", "IND", base.HEX)
f.subindex = ProtoField.uint16("uss.ind.subindex", "Subindex", base.DEC, nil, 0x00FF)
f.text_bits = ProtoField.uint16("uss.ind.text", "Text bits 8/9", base.HEX, nil, 0x0300)
f.device_bits = ProtoField.uint16("uss.ind.device", "Device-specific bits 10..15", base.DEC, nil, 0xFC00)
f.pwe = ProtoField.uint16("uss.pwe", "PWE", base.HEX_DEC)
f.value = ProtoField.uint32("uss.value", "Value", base.DEC_HEX)
f.error = ProtoField.uint16("uss.error", "Error number", base.DEC, ERRORS)
f.text = ProtoField.string("uss.text", "Text")

f.pzd = ProtoField.uint16("uss.pzd", "PZD", base.HEX)
f.cw = ProtoField.uint16("uss.cw", "Control word", base.HEX)
f.sw = ProtoField.uint16("uss.sw", "Status word", base.HEX)
local cw_bits, sw_bits = {}, {}
local mask = 1
for i = 1, #CONTROL_BITS do
    cw_bits[i] = ProtoField.bool("uss.cw.bit" .. (i - 1), CONTROL_BITS[i], 16, nil, mask)
    sw_bits[i] = ProtoField.bool("uss.sw.bit" .. (i - 1), STATUS_BITS[i], 16, nil, mask)
    f["cw_bit" .. (i - 1)] = cw_bits[i]
    f["sw_bit" .. (i - 1)] = sw_bits[i]
    mask = mask * 2
end
f.setpoint = ProtoField.int16("uss.setpoint", "Main setpoint")
f.actual = ProtoField.int16("uss.actual", "Main actual value")

local e_fault = ProtoExpert.new("uss.expert.fault", "Receive fault", expert.group.MALFORMED,
    expert.severity.ERROR)
local e_bcc = ProtoExpert.new("uss.expert.bcc", "Wrong BCC", expert.group.CHECKSUM,
    expert.severity.ERROR)
local e_problem = ProtoExpert.new("uss.expert.problem", "Exchange problem",
    expert.group.SEQUENCE, expert.severity.WARN)
local e_refused = ProtoExpert.new("uss.expert.refused", "Parameter job refused",
    expert.group.RESPONSE_CODE, expert.severity.NOTE)
local e_layout = ProtoExpert.new("uss.expert.layout", "Net data do not fit the layout",
    expert.group.MALFORMED, expert.severity.WARN)
uss.experts = { e_fault, e_bcc, e_problem, e_refused, e_layout }

uss.prefs.linktype = Pref.uint("User link type", 147,
    "pcapng link type of USS captures: 147..162 (LINKTYPE_USER0..15); pyuss writes 147 unless told")
uss.prefs.page_size = Pref.uint("Parameter numbers per IND page", 0,
    "0: PNU as it is; 2000: MICROMASTER 4 / SINAMICS, where IND bits 15, 12, 13, 14 (weights " ..
    "1, 2, 4, 8) carry the page, so PNU 10 with bit 15 is P2010")

local function band(a, mask)
    -- a AND mask for a mask of the form 2^k - 1
    return a % (mask + 1)
end

local function bxor(a, b)
    local result, bit = 0, 1
    while a > 0 or b > 0 do
        if (a % 2) ~= (b % 2) then result = result + bit end
        a, b, bit = math.floor(a / 2), math.floor(b / 2), bit * 2
    end
    return result
end

local function has(value, bit)
    return math.floor(value / bit) % 2 == 1
end

local function percent(raw)
    if raw >= 0x8000 then raw = raw - 0x10000 end
    return raw * 100 / 0x4000
end

local function dissect_pkw(tvb, tree, offset, words, direction, pkw_words, info)
    local range = tvb(offset, pkw_words * 2)
    local sub = tree:add(f.pkw, range)
    local pke = tvb(offset, 2):uint()
    local id = math.floor(pke / 4096)
    local pnu = band(pke, 0x7FF)
    local ind = tvb(offset + 2, 2):uint()
    local item = sub:add(f.pke, tvb(offset, 2))
    if direction == 2 then
        item:add(f.response_id, tvb(offset, 2))
    elseif direction == 1 then
        item:add(f.request_id, tvb(offset, 2))
    else
        item:add(f.id, tvb(offset, 2))
    end
    item:add(f.toggle, tvb(offset, 2))
    item:add(f.pnu, tvb(offset, 2))
    local ind_item = sub:add(f.ind, tvb(offset + 2, 2))
    ind_item:add(f.subindex, tvb(offset + 2, 2))
    ind_item:add(f.text_bits, tvb(offset + 2, 2))
    ind_item:add(f.device_bits, tvb(offset + 2, 2))
    local pwe = {}
    for i = 1, pkw_words - 2 do
        local at = offset + 2 + 2 * i
        pwe[i] = tvb(at, 2):uint()
        sub:add(f.pwe, tvb(at, 2)):set_text(string.format("PWE%d: 0x%04x (%d)", i, pwe[i], pwe[i]))
    end
    local names = direction == 2 and RESPONSES or REQUESTS
    local label = (names[id] or "?") .. " (" .. id .. "), PNU " .. pnu
    local page_size = uss.prefs.page_size
    if page_size > 0 then
        local page = (has(ind, 0x8000) and 1 or 0) + (has(ind, 0x1000) and 2 or 0)
            + (has(ind, 0x2000) and 4 or 0) + (has(ind, 0x4000) and 8 or 0)
        local number = pnu + page * page_size
        item:add(f.parameter, tvb(offset, 4), number)
        if page > 0 then label = label .. " (P" .. number .. ")" end
    end
    local sub_index = band(ind, 0xFF)
    local indexed = (direction == 2 and INDEXED_RESPONSES[id]) or (direction ~= 2 and INDEXED_REQUESTS[id])
    if indexed then label = label .. "[" .. (sub_index == 255 and "all" or sub_index) .. "]" end
    local pwe_start = offset + 4
    local double = (direction == 2 and DWORD_RESPONSES[id]) or (direction ~= 2 and DWORD_REQUESTS[id])
    if direction == 2 and id == 7 and #pwe >= 1 then
        local number = pwe[#pwe <= 2 and #pwe or 1]
        local at = pwe_start + 2 * ((#pwe <= 2 and #pwe or 1) - 1)
        sub:add(f.error, tvb(at, 2))
        sub:add_proto_expert_info(e_refused, "Job refused: error " .. number .. " " ..
            (ERRORS[number] or (number > 100 and "(device-specific)" or "")))
        label = label .. ", error " .. number
    elseif id == 15 and #pwe >= 1 and (direction == 2 or has(ind, 0x100)) then
        local text = tvb(pwe_start, #pwe * 2):string()
        sub:add(f.text, tvb(pwe_start, #pwe * 2), text)
        label = label .. " '" .. text:gsub("[ %z]+$", "") .. "'"
    elseif double and #pwe == 2 then
        local value = pwe[1] * 65536 + pwe[2]
        sub:add(f.value, tvb(pwe_start, 4), value)
        label = label .. " = " .. value
    elseif #pwe >= 1 and #pwe <= 2 and id ~= 0 and id ~= 15 and not (direction ~= 2 and READ_REQUESTS[id]) then
        local at = pwe_start + 2 * (#pwe - 1)
        sub:add(f.value, tvb(at, 2), pwe[#pwe])
        label = label .. " = " .. pwe[#pwe]
    end
    sub:append_text(": " .. label)
    info[#info + 1] = label
end

local function dissect_pzd(tvb, tree, offset, count, direction, info)
    for i = 1, count do
        local at = offset + 2 * (i - 1)
        local word = tvb(at, 2):uint()
        if i == 1 and direction == 1 then
            local item = tree:add(f.cw, tvb(at, 2))
            for _, field in ipairs(cw_bits) do item:add(field, tvb(at, 2)) end
            info[#info + 1] = string.format("CW %04X", word)
        elseif i == 1 and direction == 2 then
            local item = tree:add(f.sw, tvb(at, 2))
            for _, field in ipairs(sw_bits) do item:add(field, tvb(at, 2)) end
            info[#info + 1] = string.format("SW %04X", word)
        elseif i == 2 and direction == 1 then
            tree:add(f.setpoint, tvb(at, 2)):append_text(string.format(" (%.2f %%)", percent(word)))
            info[#info + 1] = string.format("SP %.2f%%", percent(word))
        elseif i == 2 and direction == 2 then
            tree:add(f.actual, tvb(at, 2)):append_text(string.format(" (%.2f %%)", percent(word)))
            info[#info + 1] = string.format("AV %.2f%%", percent(word))
        else
            tree:add(f.pzd, tvb(at, 2)):set_text(string.format("PZD%d: 0x%04x", i, word))
        end
    end
end

function uss.dissector(tvb, pinfo, root)
    if tvb:len() < 2 then return 0 end
    local hlen = tvb(1, 1):uint()
    if tvb(0, 1):uint() ~= 1 or hlen < 16 or tvb:len() < hlen then return 0 end
    pinfo.cols.protocol = "USS"
    local tree = root:add(uss, tvb())
    local head = tree:add(tvb(0, hlen), "Capture pseudo-header")
    head:add(f.version, tvb(0, 1))
    head:add(f.header_length, tvb(1, 1))
    head:add(f.direction, tvb(2, 1))
    head:add(f.fault, tvb(3, 1))
    local flags_item = head:add(f.flags, tvb(4, 2))
    for _, field in ipairs(flag_fields) do flags_item:add(field, tvb(4, 2)) end
    head:add(f.layout_pkw, tvb(6, 1))
    head:add(f.layout_pzd, tvb(7, 1))
    head:add(f.duration, tvb(8, 4))
    local delay = tvb(12, 4):int()
    if delay ~= -2147483648 then head:add(f.delay, tvb(12, 4)) end

    local direction = tvb(2, 1):uint()
    local fault = tvb(3, 1):uint()
    local flags = tvb(4, 2):uint()
    local pkw = tvb(6, 1):uint()
    local pzd = tvb(7, 1):uint()
    local info = {}
    local side = direction == 1 and "Request" or (direction == 2 and "Response" or "Frame")

    for _, item in ipairs(FLAG_NAMES) do
        if has(flags, item[1]) and item[1] >= 0x10 and item[1] <= 0x0400 then
            tree:add_proto_expert_info(e_problem, item[3])
            info[#info + 1] = "[" .. item[2] .. "]"
        end
    end
    if fault ~= 255 then
        tree:add_proto_expert_info(e_fault, "Receive fault: " .. (FAULTS[fault] or fault))
    end

    local n = tvb:len() - hlen
    local t = hlen
    if n < 4 or tvb(t, 1):uint() ~= 2 or tvb(t + 1, 1):uint() + 2 ~= n then
        tree:add(f.net, tvb(t, n)):set_text("Bytes without a whole telegram (" .. n .. ")")
        pinfo.cols.info = side .. ": " .. n .. " bytes, " .. (FAULTS[fault] or "no telegram")
        return tvb:len()
    end
    local lge = tvb(t + 1, 1):uint()
    local adr = tvb(t + 2, 1):uint()
    local address = band(adr, 0x1F)
    local mode = adr - address
    tree:add(f.stx, tvb(t, 1))
    tree:add(f.lge, tvb(t + 1, 1)):append_text(" (" .. (lge - 2) .. " net bytes)")
    local adr_item = tree:add(f.adr, tvb(t + 2, 1))
    adr_item:add(f.address, tvb(t + 2, 1))
    adr_item:add(f.mode, tvb(t + 2, 1))
    local net_len = lge - 2
    local net_at = t + 3
    local check = 0
    for i = 0, n - 2 do check = bxor(check, tvb(t + i, 1):uint()) end
    local bcc = tvb(t + n - 1, 1):uint()
    local bcc_item = tree:add(f.bcc, tvb(t + n - 1, 1))
    bcc_item:add(f.bcc_ok, tvb(t + n - 1, 1), check == bcc)
    if check ~= bcc then
        bcc_item:add(f.bcc_expected, tvb(t + n - 1, 1), check)
        bcc_item:add_proto_expert_info(e_bcc, string.format("BCC is %02X, expected %02X", bcc, check))
    end

    local where = MODES[mode] or "undefined type"
    if mode == 0x20 or mode == 0xA0 then
        pinfo.cols.src = "master"
        pinfo.cols.dst = "broadcast"
    elseif direction == 2 then
        pinfo.cols.src = "slave " .. address
        pinfo.cols.dst = "master"
    else
        pinfo.cols.src = "master"
        pinfo.cols.dst = "slave " .. address
    end

    if net_len > 0 then
        local net = tree:add(f.net, tvb(net_at, net_len))
        local words = math.floor(net_len / 2)
        local decodable = (mode == 0x00 or mode == 0x20) and pkw ~= 255 and pzd ~= 255 and net_len % 2 == 0
        local pkw_words
        if decodable then
            if pkw == 127 then
                pkw_words = words - pzd
                if pkw_words < 3 then decodable = false end
            else
                pkw_words = pkw
                if pkw + pzd ~= words then decodable = false end
            end
        end
        if decodable then
            if pkw_words > 0 then
                dissect_pkw(tvb, net, net_at, words, direction, pkw_words, info)
            end
            dissect_pzd(tvb, net, net_at + 2 * pkw_words, pzd, direction, info)
        elseif (mode == 0x00 or mode == 0x20) and pkw ~= 255 then
            net:add_proto_expert_info(e_layout, "Net data do not fit layout " ..
                (pkw == 127 and "v" or pkw) .. "," .. pzd)
        end
    end
    local text = side .. " adr " .. address
    if mode ~= 0 then text = side .. " " .. where .. (mode == 0x20 and "" or " adr " .. address) end
    if fault ~= 255 then text = text .. " [" .. (FAULTS[fault] or "fault") .. "]" end
    pinfo.cols.info = text .. (#info > 0 and ": " .. table.concat(info, ", ") or "")
    return tvb:len()
end

local registered = nil
local function register()
    local table_ = DissectorTable.get("wtap_encap")
    if registered ~= nil then table_:remove(registered, uss) end
    local linktype = uss.prefs.linktype
    if linktype < 147 or linktype > 162 then linktype = 147 end
    registered = wtap_encaps["USER" .. (linktype - 147)]
    table_:add(registered, uss)
end

function uss.prefs_changed()
    register()
end

register()
