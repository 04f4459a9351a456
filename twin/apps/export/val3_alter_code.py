"""The VAL3 source of the alter application's programs (`twin.apps.export.val3_alter`, whose docstring says what
each does and after which public code): `start` (the path as `alter` moves), `alterTask` (the synchronous task
that takes the twin's correction each 4 ms and stops the motion when the link fails) and `stop` (the motion
reset and the link closed). Templates for `str.format`: the writer fills in the program's names, sizes and limits.
"""

STOP_CODE = """begin
  // stop: the application ends (the operator, an error): the motion reset and the link to the twin closed, as
  // ros-industrial staubli_val3_driver's stop.pgx does (resetMotion(), taskKill of its tasks)
  bAlterRun = false
  bAlterOn = false
  resetMotion()
  taskKill("{task}")
  clearBuffer(siTwin)
end"""

START_CODE = """begin
  // {name}: {n} points of {source}, sheet frame fSheet, tool tIsf, robot {robot}
{about}  // online correction: {task} (every {cycle_ms:g} ms) sends the joints to the twin (tx200-twin online) on siTwin
  // and applies its answer with alter(): the path's moves are alterMovel, altered in world
  bAlterOn = false
  bAlterRun = true
  bTwinLost = false
  nAlterHeld = 0
  nAlterBad = 0
  nTwinErr = 0
  movej(jHome, tIsf, mApproach)
  movej(pPath[0], tIsf, mApproach)
  waitEndMove()
  taskCreateSync "{task}", {cycle_s:g}, bAlterOver, {task}()
  alterBegin(world, mPath[1])
  bAlterOn = true
  for i = 1 to size(pPath) - 2
    // a failed link ({task} sets bTwinLost and resets the motion): no more moves queued
    if bTwinLost == false
      alterMovel(pPath[i], tIsf, mPath[i])
    endIf
  endFor
  waitEndMove()
  bAlterOn = false
  alterEnd()
  if bTwinLost == false
    movel(pPath[size(pPath) - 1], tIsf, mPath[size(pPath) - 1])
    waitEndMove()
    movej(jHome, tIsf, mApproach)
    waitEndMove()
  endIf
  // bTwinLost: forming stopped where the link failed, the tool on the sheet; clear it by hand
  bAlterRun = false
end"""

TASK_CODE = """begin
  // Synchronous task ({cycle_ms:g} ms): the twin's newest fresh answer into alter(), then the joints now to the twin.
  // Frames (twin.apps.online.alter_protocol), little-endian: request magic, seq, j1..j6 [deg] ({request} bytes);
  // answer magic, seq, dx dy dz [mm], absolute, world frame ({answer} bytes).
  sioCtrl(siTwin, "timeout", -1)
  clearBuffer(siTwin)
  l_nMagic = {magic}
  l_nSeq = 0
  l_nApplied = 0
  l_nGot = 0
  l_nSilent = 0
  toBinary(l_nMagic, 1, "{int32}", l_nTx[0])
  while bAlterRun
    // the answers waiting, byte by byte (a frame may come in pieces), at most {answers} frames a cycle
    l_nFresh = 0
    l_nBytes = 0
    l_nRead = 1
    while l_nRead == 1
      l_nRead = 0
      if l_nBytes < {max_bytes}
        l_nRead = sioGet(siTwin, l_nByte)
      endIf
      if l_nRead == 1
        l_nRx[l_nGot] = l_nByte
        l_nGot = l_nGot + 1
        l_nBytes = l_nBytes + 1
      endIf
      if l_nGot == {answer}
        l_nGot = 0
        l_nOk = fromBinary(l_nRx[0], 4, "{int32}", l_nAnsMagic)
        l_nOk = l_nOk + fromBinary(l_nRx[4], 4, "{int32}", l_nAnsSeq)
        for l_nI = 0 to 2
          l_nOk = l_nOk + fromBinary(l_nRx[8 + 4 * l_nI], 4, "{float32}", l_nC[l_nI])
        endFor
        l_nUse = 0
        if l_nOk == 5
          if l_nAnsMagic == l_nMagic
            l_nUse = 1
          endIf
        endIf
        if l_nUse == 0
          nAlterBad = nAlterBad + 1
        endIf
        // fresh: newer than the last applied, not newer than the last sent, less than {max_age} requests behind it
        if l_nAnsSeq <= l_nApplied
          l_nUse = 0
        endIf
        if l_nAnsSeq > l_nSeq
          l_nUse = 0
        endIf
        if l_nAnsSeq <= l_nSeq - {max_age}
          l_nUse = 0
        endIf
        if l_nUse == 1
          l_nApplied = l_nAnsSeq
          l_nFresh = 1
          for l_nI = 0 to 2
            l_nA[l_nI] = l_nC[l_nI]
          endFor
        endIf
      endIf
    endWhile
    // a failed link: a socket error (sioGet -1), or no fresh answer for {silent} cycles while altering
    if l_nRead < 0
      bTwinLost = true
    endIf
    l_nSilent = l_nSilent + 1
    if l_nFresh == 1
      l_nSilent = 0
    endIf
    if bAlterOn
      if l_nSilent >= {silent}
        bTwinLost = true
      endIf
    endIf
    if bTwinLost
      // forming stops: the motion reset (every cycle, so a move queued after the failure is cancelled too),
      // no correction applied, nothing sent
      resetMotion()
      l_nFresh = 0
    endIf
    if l_nFresh == 1
      // second guard: at most nAlterMax mm, whatever came
      l_nNorm = sqrt(l_nA[0] * l_nA[0] + l_nA[1] * l_nA[1] + l_nA[2] * l_nA[2])
      l_nScale = 1
      if l_nNorm > nAlterMax
        l_nScale = nAlterMax / l_nNorm
      endIf
      trAlter.x = l_nA[0] * l_nScale
      trAlter.y = l_nA[1] * l_nScale
      trAlter.z = l_nA[2] * l_nScale
      if bAlterOn
        alter(trAlter)
      endIf
    else
      // no fresh answer: the alteration holds (until the link counts as failed, above)
      nAlterHeld = nAlterHeld + 1
    endIf
    if bTwinLost == false
      // the joints now, with the next sequence number
      l_jNow = herej()
      l_nJ[0] = l_jNow.j1
      l_nJ[1] = l_jNow.j2
      l_nJ[2] = l_jNow.j3
      l_nJ[3] = l_jNow.j4
      l_nJ[4] = l_jNow.j5
      l_nJ[5] = l_jNow.j6
      l_nSeq = l_nSeq + 1
      toBinary(l_nSeq, 1, "{int32}", l_nTx[4])
      toBinary(l_nJ, {joints}, "{float32}", l_nTx[8])
      if sioSet(siTwin, l_nTx) != size(l_nTx)
        // a failed send: the link failed, forming stops
        nTwinErr = nTwinErr + 1
        bTwinLost = true
        resetMotion()
      endIf
    endIf
    delay(0)
  endWhile
  clearBuffer(siTwin)
end"""
