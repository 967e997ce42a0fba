// The paper's one-link servo arm (0-120 degrees) driven by `imimic mimic --serial PORT`.
//
// Protocol (imimic_gym/servo.py): one text line per joint command, host to board,
// 115200 baud 8N1:
//     J<joint> <degrees>\n      e.g. "J1 87.5\n"
// The board answers nothing after its start-up line, clamps every angle to the servo's
// range again (a mistyped line must not drive the horn into its stop) and holds the last
// position. Lines it does not understand are ignored.
//
// Wiring: servo signal on pin 9, servo power from its own 5 V supply (not the board's
// regulator: a stalled hobby servo draws more than it can give), grounds joined.

#include <Servo.h>

const int SERVO_PIN = 9;
const float SERVO_MIN_DEG = 0.0;
const float SERVO_MAX_DEG = 120.0;
const float START_DEG = 60.0;       // joint angle 0: the middle of the range
// Pulse widths of this servo at 0 and 180 degrees (microseconds); check the datasheet.
const int PULSE_AT_0 = 544;
const int PULSE_AT_180 = 2400;

Servo joint1;
char line[24];
byte length = 0;

void moveTo(float degrees) {
  if (degrees < SERVO_MIN_DEG) degrees = SERVO_MIN_DEG;
  if (degrees > SERVO_MAX_DEG) degrees = SERVO_MAX_DEG;
  // Microseconds, not Servo.write(): a tenth of a degree is about one microsecond.
  long pulse = PULSE_AT_0 + (long)((PULSE_AT_180 - PULSE_AT_0) * degrees / 180.0 + 0.5);
  joint1.writeMicroseconds((int)pulse);
}

void handle(const char *text) {
  if (text[0] != 'J') return;
  char *rest;
  long joint = strtol(text + 1, &rest, 10);
  if (rest == text + 1 || *rest != ' ') return;
  float degrees = atof(rest + 1);
  if (joint == 1) moveTo(degrees);  // this arm has one joint; others are ignored
}

void setup() {
  Serial.begin(115200);
  joint1.attach(SERVO_PIN);
  moveTo(START_DEG);
  Serial.println("imimic servo arm ready");
}

void loop() {
  while (Serial.available() > 0) {
    char c = Serial.read();
    if (c == '\n') {
      line[length] = '\0';
      handle(line);
      length = 0;
    } else if (c != '\r' && length < sizeof(line) - 1) {
      line[length++] = c;
    }
  }
}
