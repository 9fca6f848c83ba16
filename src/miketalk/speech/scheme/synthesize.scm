;;; miketalk: text -> wav + timed phones with Festival (voice_kal_diphone).
;;;
;;; Run as `festival -b synthesize.scm`. Everything comes in through environment
;;; variables; the user's text is read with getenv and only ever used as a string
;;; datum, never spliced into a Scheme expression.
;;;   MIKETALK_VOICE     the voice, one of the names allowed below
;;;   MIKETALK_OUT       a directory; chunk I is written as I.wav (RIFF) and
;;;                      I.phones (one "name end-seconds" line per Segment)
;;;   MIKETALK_CHUNKS    how many chunks of text there are
;;;   MIKETALK_TEXT_I    chunk I's text (I = 0 .. MIKETALK_CHUNKS - 1)
;;;   MIKETALK_ENDS_I    optional: a file holding one list of numbers, chunk I's
;;;                      dictated Segment end times in seconds. When given, the
;;;                      text modules run up to Duration, the ends are set, and
;;;                      only then Int_Targets and Wave_Synth (re-synthesis).

(define (miketalk-env name)
  (let ((v (getenv name)))
    ;; getenv's value is re-read when handed to Utterance; a fresh string is not
    (if v (string-append "" v) nil)))

(define (miketalk-voice)
  (let ((name (miketalk-env "MIKETALK_VOICE")))
    (cond
     ((equal? name "voice_kal_diphone") (voice_kal_diphone))
     (t (format stderr "miketalk: unsupported voice %s\n" name) (exit 3)))))

(define (miketalk-read-ends path)
  (let ((fd (fopen path "r")) (ends nil))
    (set! ends (readfp fd))
    (fclose fd)
    ends))

(define (miketalk-set-ends utt ends)
  (let ((segs (utt.relation.items utt 'Segment)))
    (if (not (equal? (length segs) (length ends)))
        (begin
          (format stderr "miketalk: %d durations for %d phones\n" (length ends) (length segs))
          (exit 4)))
    (mapcar (lambda (seg end) (item.set_feat seg "end" end)) segs ends)))

(define (miketalk-write-phones utt path)
  (let ((fd (fopen path "w")))
    (mapcar
     (lambda (seg) (format fd "%s %.6f\n" (item.name seg) (item.feat seg "end")))
     (utt.relation.items utt 'Segment))
    (fclose fd)))

(define (miketalk-chunk i)
  (let ((utt (eval (list 'Utterance 'Text (miketalk-env (format nil "MIKETALK_TEXT_%d" i)))))
        (ends-file (miketalk-env (format nil "MIKETALK_ENDS_%d" i)))
        (out (miketalk-env "MIKETALK_OUT")))
    (if ends-file
        (begin
          (Initialize utt) (Text utt) (Token_POS utt) (Token utt) (POS utt) (Phrasify utt)
          (Word utt) (Pauses utt) (Intonation utt) (PostLex utt) (Duration utt)
          (miketalk-set-ends utt (miketalk-read-ends ends-file))
          (Int_Targets utt) (Wave_Synth utt))
        (utt.synth utt))
    (utt.save.wave utt (format nil "%s/%d.wav" out i) 'riff)
    (miketalk-write-phones utt (format nil "%s/%d.phones" out i))))

(define (miketalk-chunks i n)
  (if (< i n)
      (begin (miketalk-chunk i) (miketalk-chunks (+ i 1) n))))

(miketalk-voice)
(miketalk-chunks 0 (parse-number (miketalk-env "MIKETALK_CHUNKS")))
