"""The field procedure of the bi-directional UMBmark test, as text (``umbmark guide``)."""

from __future__ import annotations

__all__ = ["guide_text", "STEP_TITLES"]

STEP_TITLES = (
    "Before you start",
    "Mark three reference points on the robot",
    "Choose the start area: the corner of two perpendicular walls",
    "Program the square",
    "One run, step by step",
    "5 runs each way",
    "What to type",
    "Compute the calibration",
    "Load it and check",
)


def guide_text(side_mm: float = 4000.0, runs: int = 5, speed_m_s: float = 0.2) -> str:
    """The field procedure of the UMBmark test, step by step.

    Parameters
    ----------
    side_mm : float
        The side of the square.
    runs : int
        Runs per direction.
    speed_m_s : float
        The driving speed the procedure names.

    Returns
    -------
    str
        Plain text, at most 100 columns, one numbered step per :data:`STEP_TITLES` entry.
    """
    L = f"{side_mm:g}"
    Lm = f"{side_mm / 1000:g}"
    steps = [
        f"""Tyres at their usual pressure, the usual load on board, batteries charged: the calibration
   holds for the robot as it drives every day. Check the distance scale first (the square test
   cannot see it): drive {Lm} m straight, measure the distance travelled with the tape, and correct
   the nominal wheel diameter if the odometry disagrees.""",
        """Two marks on the same side of the robot, one near the front and one near the rear, as far
   apart as possible (e.g. two chassis corners), and one at the middle of the back. Measure their
   coordinates in the ROBOT frame, in millimetres: origin at the midpoint of the wheel axle, x
   forward, y to the left (points on the right side have negative y). These are --front X,Y,
   --rear X,Y and --back X,Y of `umbmark measure`. Put the same marks on the other side too
   (mirrored): the cw and ccw runs use opposite sides.""",
        f"""Find a corner of two walls at right angles with {Lm} x {Lm} m of free, flat floor next to it.
   The "back wall" is behind the robot, the "side wall" runs along the robot's side, the robot
   faces along the side wall into the room, 30 to 50 cm from both walls. The square must turn
   AWAY from the side wall: for the cw runs (right turns) the side wall is on the robot's LEFT,
   for the ccw runs (left turns) on its RIGHT: use the two corners at the two ends of one back
   wall. Mark each start with tape around the wheels so you can put the robot back on it.""",
        f"""The robot drives four {L} mm legs and turns 90 degrees on the spot at each corner, stopping
   after each leg (the paper: {speed_m_s:g} m/s). A cw run starts along +x (the first leg) and turns
   right; a ccw run starts along +x and turns left. The controller only needs to get back near
   the start: the test measures the odometry, not the controller.""",
        """  a. Put the robot on the start marks.
  b. START distances, in mm, each perpendicular to the wall, tape flat on the floor:
     front mark -> side wall, rear mark -> side wall, back mark -> back wall.
  c. Reset the odometry to x = 0, y = 0, theta = 0 (the START FRAME: x along the first leg,
     y to the left, angles counter-clockwise).
  d. Run the square. Do not touch the robot afterwards.
  e. Read the robot's odometry at the end: x_odo, y_odo (mm) and theta_odo (deg), as it
     reports them in the start frame.
  f. END distances: the same three measurements again, against the same two walls.
  umbmark measure turns these six distances into where the robot really stopped, in the start
  frame (x_abs, y_abs, theta_abs), and propagates the tape's resolution into its error.""",
        f"""{runs} runs clockwise and {runs} runs counter-clockwise (the paper: 5 each way). More runs shrink
   the error of the centres of gravity (SEM = sigma / sqrt(n)). Note anything odd (a wheel
   slipped, a bump) and repeat that run rather than editing the numbers.""",
        """One row per run in a CSV file (mm and degrees), e.g. distances.csv:

   run,direction,start_front,start_rear,start_back,end_front,end_rear,end_back,x_odo,y_odo,theta_odo
   1,cw,409,411,350,294,278,471,45.7,44.9,-1.30
   1,ccw,409,411,350,188,150,633,43.7,-44.9,1.29

   Empty start cells reuse the previous start of the same direction. Or type the rows
   at the prompts: umbmark measure --interactive ... (it saves after every run). If you measure
   the end pose another way (a motion-capture system, a grid on the floor), write the runs file
   directly: run,direction,x_abs,y_abs,x_odo,y_odo[,theta_abs,theta_odo], in the start frame.""",
        f"""umbmark measure distances.csv --front 150,-120 --rear -150,-120 --back -200,0 --out runs.csv
   umbmark analyze runs.csv --wheelbase-mm <nominal> --side-mm {L} --robot <name> --record
   analyze prints E_max,syst, the correction factors c_left, c_right and the corrected
   wheelbase; --record stores them in the robot's history (umbmark history <name>).""",
        """Load c_left, c_right and the new wheelbase into the robot's odometry (umbmark history <name>
   --export params.json writes them) and run the test again. E_max,syst should drop roughly
   ten-fold (the paper: 317 mm -> 21 mm). If it is still above 3 x SEM, analyze the new runs
   with --c-left/--c-right/--wheelbase-mm set to what the robot now uses (a second pass).
   Re-run the test when the load or the tyres change: umbmark history <name> --plot shows drift.""",
    ]
    out = [f"UMBmark field procedure (bi-directional square test, {L} mm sides)", ""]
    for i, (title, body) in enumerate(zip(STEP_TITLES, steps), 1):
        out.append(f"{i}. {title}")
        out.append(body if body.startswith("  ") else "   " + body)
        out.append("")
    return "\n".join(out).rstrip() + "\n"
